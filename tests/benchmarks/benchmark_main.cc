// skidimm_benchmarks: the performance figures of docs/performance.md.
//
//   build/bin/skidimm_benchmarks                      # everything, 5 interleaved repetitions
//   build/bin/skidimm_benchmarks --benchmark_filter=Imm/\|Reference/
//
// Absolute times on a shared machine are noise; ratios taken in one run are
// not. Unless told otherwise on the command line, every benchmark is repeated
// 5 times in random interleaved order and the tables at the end use the
// medians: the engine's step as a multiple of the hand-written fixed-size IMM
// (tests/core/reference_imm.h) on the same steps, the share of one core each
// bank size takes at 100 Hz, and `skidimm run` rows per second.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "benchmark_support.h"
#include "core/malloc_counter.h"

namespace skidimm_bench {

long malloc_calls() { return skidimm_test::g_malloc_calls.load(); }
long malloc_bytes() { return skidimm_test::g_malloc_bytes.load(); }

namespace {

struct Figure {
  double seconds = 0.0;  // per iteration: median over repetitions, else the one run
  std::map<std::string, double> counters;
  bool from_median = false;
};

double to_seconds(double time, benchmark::TimeUnit unit) {
  switch (unit) {
    case benchmark::kNanosecond:
      return time * 1e-9;
    case benchmark::kMicrosecond:
      return time * 1e-6;
    case benchmark::kMillisecond:
      return time * 1e-3;
    case benchmark::kSecond:
      return time;
  }
  return time;
}

class FigureReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      const std::string name = run.run_name.str();
      const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
      const bool single = run.run_type == Run::RT_Iteration;
      Figure& f = figures_[name];
      if (!(median || (single && !f.from_median))) continue;
      // Run/ times the child process with manual time (its CPU time); the rest
      // are this process's CPU time.
      const double time = name.rfind("Run/", 0) == 0 ? run.GetAdjustedRealTime() : run.GetAdjustedCPUTime();
      f.seconds = to_seconds(time, run.time_unit);
      for (const auto& [key, counter] : run.counters) f.counters[key] = counter.value;
      f.from_median = median;
    }
    ConsoleReporter::ReportRuns(runs);
  }

  void Finalize() override {
    ConsoleReporter::Finalize();
    print_ratios();
    print_scaling();
    print_runs();
  }

 private:
  const Figure* find(const std::string& name) const {
    const auto it = figures_.find(name);
    return it == figures_.end() ? nullptr : &it->second;
  }

  void print_ratios() const {
    bool header = false;
    for (const auto& [bank, size] : std::vector<std::pair<std::string, std::string>>{
             {"ltc_terrains", "3 x 2"}, {"stc_slip4", "4 x 3"}, {"stc_slip16", "16 x 3"}, {"ltc16", "16 x 2"}}) {
      const Figure* imm = find("Imm/" + bank);
      const Figure* reference = find("Reference/" + bank);
      if (imm == nullptr || reference == nullptr) continue;
      if (!header) {
        std::printf("\nImm::step against the hand-written fixed-size IMM, same steps, same run (%s):\n",
                    imm->from_median ? "medians" : "single runs");
        std::printf("  %-14s %-14s %12s %16s %8s\n", "bank", "modes x states", "Imm (us)", "reference (us)", "ratio");
        header = true;
      }
      std::printf("  %-14s %-14s %12.3f %16.3f %7.2fx\n", bank.c_str(), size.c_str(), imm->seconds * 1e6,
                  reference->seconds * 1e6, imm->seconds / reference->seconds);
    }
  }

  void print_scaling() const {
    bool header = false;
    for (const char* states : {"ltc", "stc"}) {
      for (int modes : {1, 4, 16, 64, 256}) {
        std::string row;
        bool any = false;
        for (const char* form : {"per_step", "uniform_dwell", "per_mode_dwell"}) {
          const Figure* f = find(std::string("Scaling/") + form + "/" + states + "/" + std::to_string(modes));
          char cell[64];
          if (f == nullptr) {
            std::snprintf(cell, sizeof(cell), " %22s", "-");
          } else {
            // A step every 10 ms: the share of a core is the step time / 10 ms.
            std::snprintf(cell, sizeof(cell), " %10.2f us %7.3f%%", f->seconds * 1e6, f->seconds / 0.01 * 100.0);
            any = true;
          }
          row += cell;
        }
        if (!any) continue;
        if (!header) {
          std::printf("\nImm::step and the share of one core at 100 Hz (dt jittered +-10%%):\n");
          std::printf("  %-6s %6s %22s %22s %22s\n", "states", "modes", "per-step matrix", "equal dwell times",
                      "per-mode dwell times");
          header = true;
        }
        std::printf("  %-6s %6d%s\n", std::strcmp(states, "ltc") == 0 ? "2 ltc" : "3 stc", modes, row.c_str());
      }
    }
  }

  void print_runs() const {
    bool header = false;
    for (const auto& [name, f] : figures_) {
      if (name.rfind("Run/", 0) != 0 && name.rfind("RunLoop/", 0) != 0) continue;
      if (!header) {
        std::printf("\nskidimm run over a log (Run/: the executable end to end, CPU time of the child; RunLoop/: "
                    "the same loop in process):\n");
        header = true;
      }
      const auto rows = f.counters.find("rows");
      const auto allocations = f.counters.find("allocs_per_row");
      const double rows_per_second = rows == f.counters.end() ? 0.0 : rows->second / f.seconds;
      std::string shown = name;
      for (const char* suffix : {"/manual_time", "/iterations:1"}) {
        const auto at = shown.find(suffix);
        if (at != std::string::npos) shown.erase(at, std::strlen(suffix));
      }
      std::printf("  %-24s %10.0f rows/s", shown.c_str(), rows_per_second);
      if (allocations != f.counters.end()) std::printf("   %.2g heap allocations per row", allocations->second);
      std::printf("\n");
    }
  }

  std::map<std::string, Figure> figures_;
};

}  // namespace
}  // namespace skidimm_bench

int main(int argc, char** argv) {
  // Default: 5 repetitions, interleaved, medians only on the console.
  std::vector<char*> args(argv, argv + argc);
  bool repetitions_given = false;
  for (int i = 1; i < argc; ++i) repetitions_given = repetitions_given || std::strstr(argv[i], "repetitions") != nullptr;
  static char repetitions[] = "--benchmark_repetitions=5";
  static char interleave[] = "--benchmark_enable_random_interleaving=true";
  static char aggregates[] = "--benchmark_display_aggregates_only=true";
  if (!repetitions_given) {
    args.push_back(repetitions);
    args.push_back(interleave);
    args.push_back(aggregates);
  }
  int count = static_cast<int>(args.size());
  benchmark::Initialize(&count, args.data());
  skidimm_bench::FigureReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
