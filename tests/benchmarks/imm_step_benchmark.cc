// Speed and memory of one IMM step as the bank grows.
//
// Absolute times depend on the machine; ratios within one run do not, so the
// report ends with each bank size's time per step as a multiple of the
// one-mode bank (a plain EKF), measured in the same run. Memory is the heap
// the Imm takes at construction (malloc is counted), and the heap it
// takes per step (which must be 0).
//   build/bin/skidimm_benchmarks
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "core/malloc_counter.h"
#include "core/test_banks.h"
#include "skidimm/imm.h"

namespace {

skidimm::Bank make_ltc_bank(int num_modes) {
  skidimm_test::BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d input;
  input << 0.4, 0.4, -0.8, 0.8;
  for (int j = 0; j < num_modes; ++j) {
    b.models.push_back(
        skidimm_test::make_ltc(Eigen::Matrix2d::Identity() * -(1.0 + 0.1 * j), (0.3 + 0.01 * j) * input));
  }
  b.q = {Eigen::Matrix2d::Identity() * 0.01};
  b.r = Eigen::Matrix2d::Identity() * 0.01;
  return b.build();
}

void BM_ImmStep(benchmark::State& state) {
  skidimm::Bank bank = make_ltc_bank(static_cast<int>(state.range(0)));
  const long bytes_before = skidimm_test::g_malloc_bytes.load();
  skidimm::Imm imm(std::move(bank));
  const long construction_bytes = skidimm_test::g_malloc_bytes.load() - bytes_before;
  double t = 0.0;
  const long allocations_before = skidimm_test::g_malloc_calls.load();
  for (auto _ : state) {
    t += 0.02;
    const auto& e = imm.step(t, Eigen::Vector2d(3.0, 4.0), Eigen::Vector2d(0.5 + 0.1 * std::sin(t), 0.1));
    benchmark::DoNotOptimize(e.state.data());
  }
  state.counters["imm_bytes"] = static_cast<double>(construction_bytes);
  state.counters["allocs_per_step"] = static_cast<double>(skidimm_test::g_malloc_calls.load() - allocations_before) /
                                      static_cast<double>(state.iterations());
}
BENCHMARK(BM_ImmStep)->Arg(1)->Arg(4)->Arg(16)->Arg(64)->Arg(256);

// Prints each run as usual, then the time per step relative to the first run.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.run_type == Run::RT_Iteration) times_.emplace_back(run.benchmark_name(), run.GetAdjustedCPUTime());
    }
    ConsoleReporter::ReportRuns(runs);
  }
  void Finalize() override {
    ConsoleReporter::Finalize();
    if (times_.empty()) return;
    const double reference = times_.front().second;  // registered first: the one-mode bank
    std::printf("\ntime per step relative to BM_ImmStep/1 (one mode, a plain EKF) in this run:\n");
    for (const auto& [name, time] : times_) std::printf("  %-16s %8.1fx\n", name.c_str(), time / reference);
  }

 private:
  std::vector<std::pair<std::string, double>> times_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  return 0;
}
