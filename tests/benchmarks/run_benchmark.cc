// `skidimm run` over a long log, end to end: reading, stepping, writing.
//
//   Run/<bank>[/npy]: the skidimm executable as a user runs it, on a log of
//     SKIDIMM_BENCHMARK_ROWS rows (default 1,000,000) made by repeating the
//     bank's bundled example log (configs/examples/, 19 columns as the
//     simulator writes them, GPS in one row of five); the time is the child
//     process's CPU time (user + system), so rows/s is per core. /npy writes
//     a NumPy array instead of CSV. SKIDIMM_BENCHMARK_EXECUTABLE runs another
//     build's skidimm (an older one, for comparison).
//   RunFloor/<bank>[/npy]: the I/O floor of Run/<bank>[/npy], timed in the
//     same way (CPU time, user + system): the same log read by the same
//     reader (LogReader: every column the bank reads, parsed), and the same
//     rows written by the same writer, byte for byte what `skidimm run`
//     writes, from estimates computed beforehand (untimed). Nothing else:
//     no filter, no decision, no summary. Run/ over RunFloor/ is what the
//     estimator costs on top of reading and writing.
//   RunLoop/<bank>: the same loop in this process (log_run.h,
//     write_estimates), counting heap allocations per row from the 1024th row
//     on (before it the Imm and its workspaces are built).
// The logs are made once under the system's temporary directory.
#include <benchmark/benchmark.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "benchmark_data.h"
#include "benchmark_support.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/estimates_writer.h"

extern char** environ;

namespace skidimm_bench {
namespace {

long benchmark_rows() {
  const char* rows = std::getenv("SKIDIMM_BENCHMARK_ROWS");
  return rows != nullptr ? std::atol(rows) : 1000000;
}

std::string executable() {
  const char* other = std::getenv("SKIDIMM_BENCHMARK_EXECUTABLE");
  return other != nullptr ? other : SKIDIMM_EXECUTABLE;
}

std::filesystem::path work_directory() {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "skidimm_benchmark_logs";
  std::filesystem::create_directories(dir);
  return dir;
}

// The example log repeated, times shifted, to `rows` data rows.
std::filesystem::path long_log(const std::string& example, long rows) {
  const std::filesystem::path path = work_directory() / (example + "_" + std::to_string(rows) + ".csv");
  if (std::filesystem::exists(path)) return path;
  std::ifstream in(source_dir() / "configs" / "examples" / (example + ".csv"));
  std::string header, line;
  std::getline(in, header);
  std::vector<std::pair<double, std::string>> lines;  // time, the rest of the row
  while (std::getline(in, line)) {
    const auto comma = line.find(',');
    lines.emplace_back(std::stod(line.substr(0, comma)), line.substr(comma));
  }
  const double period = lines.back().first + (lines.back().first - lines.front().first) / (lines.size() - 1);
  const std::filesystem::path partial = path.string() + ".partial";
  {
    std::FILE* out = std::fopen(partial.c_str(), "wb");
    std::fprintf(out, "%s\n", header.c_str());
    for (long k = 0; k < rows; ++k) {
      const auto& [t, rest] = lines[static_cast<std::size_t>(k % static_cast<long>(lines.size()))];
      std::fprintf(out, "%.4f%s\n", t + period * static_cast<double>(k / static_cast<long>(lines.size())),
                   rest.c_str());
    }
    std::fclose(out);
  }
  std::filesystem::rename(partial, path);
  return path;
}

// The size of an output, with the reason table of a .npy.
double output_bytes(const std::filesystem::path& output) {
  std::error_code missing;
  double bytes = static_cast<double>(std::filesystem::file_size(output, missing));
  if (skidimm::EstimatesWriter::is_npy(output)) {
    bytes += static_cast<double>(std::filesystem::file_size(skidimm::EstimatesWriter::reasons_path(output), missing));
  }
  return missing ? 0.0 : bytes;
}

const char* example_of(const std::string& bank) {
  return bank.rfind("ltc", 0) == 0 ? "ltc_switching" : "stc_switching";
}

void run_executable(benchmark::State& state, const std::string& bank, const std::string& extension) {
  const long rows = benchmark_rows();
  const std::filesystem::path log = long_log(example_of(bank), rows);
  const std::string output = (work_directory() / ("out_" + bank + extension)).string();
  const std::string bank_file = (source_dir() / "configs" / (bank + ".yaml")).string();
  const std::string program = executable();
  std::vector<std::string> args = {program, "run", "-q", "--bank", bank_file, "--input", log.string(),
                                   "--output", output};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  double wall = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    pid_t pid = 0;
    if (posix_spawn(&pid, program.c_str(), nullptr, nullptr, argv.data(), environ) != 0) {
      state.SkipWithError("cannot start skidimm");
      return;
    }
    int status = 0;
    rusage usage{};
    wait4(pid, &status, 0, &usage);
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      state.SkipWithError("skidimm run failed");
      return;
    }
    const double cpu = static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
                       1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
    state.SetIterationTime(cpu);
  }
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["output_bytes"] = output_bytes(output);
  state.counters["wall_rows_per_second"] =
      benchmark::Counter(static_cast<double>(rows) * static_cast<double>(state.iterations()) / wall);
}

double thread_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// What `skidimm run` writes for each row of a log, held in memory: the
// numbers, the most likely mode, the decision and the status.
struct RecordedEstimates {
  std::vector<double> numbers;  // per row: mu (modes), state (n), variances (n)
  std::vector<int> modes;
  std::vector<int> decisions;
  std::vector<skidimm::StepStatus> statuses;
};

RecordedEstimates record_estimates(const skidimm::Bank& bank, const std::filesystem::path& log, bool* with_reasons) {
  RecordedEstimates r;
  skidimm::LogReader reader(bank.config, {log});
  skidimm::ModeDecision decision(bank.config, bank.config.decision);
  skidimm::run_log(bank, &reader, {}, [&](const skidimm::LogSample& sample, const skidimm::ImmEstimate& e) {
    for (Eigen::Index j = 0; j < e.mode_probabilities.size(); ++j) r.numbers.push_back(e.mode_probabilities[j]);
    for (Eigen::Index i = 0; i < e.state.size(); ++i) r.numbers.push_back(e.state[i]);
    for (Eigen::Index i = 0; i < e.state.size(); ++i) r.numbers.push_back(e.covariance(i, i));
    r.modes.push_back(e.most_likely_mode);
    r.decisions.push_back(decision.update(sample.t, e.mode_probabilities));
    r.statuses.push_back(e.status);
    *with_reasons = *with_reasons || e.num_rejected_modes > 0 || e.num_gated_modes > 0;
  });
  return r;
}

void run_floor(benchmark::State& state, const std::string& bank_name, const std::string& extension) {
  const long rows = benchmark_rows();
  const std::filesystem::path log = long_log(example_of(bank_name), rows);
  const skidimm::Bank bank = bundled_bank(bank_name);
  const std::filesystem::path output = work_directory() / ("floor_" + bank_name + extension);
  bool with_reasons = false;
  const RecordedEstimates recorded = record_estimates(bank, log, &with_reasons);
  if (with_reasons) {
    // The floor writes no reasons; a log with some would make it too low.
    state.SkipWithError("the example log has rows with a reason; the floor writes none");
    return;
  }
  const skidimm::ModeDecision names(bank.config, bank.config.decision);
  const Eigen::Index modes = bank.config.num_modes();
  const Eigen::Index n = static_cast<Eigen::Index>(bank.config.state_names.size());
  skidimm::ImmEstimate e;
  e.mode_probabilities.resize(modes);
  e.state.resize(n);
  e.covariance = Eigen::MatrixXd::Zero(n, n);
  e.mode_failures.assign(static_cast<std::size_t>(modes), skidimm::ModeFailure::kNone);
  for (auto _ : state) {
    const double start = thread_cpu_seconds();
    skidimm::LogReader reader(bank.config, {log});
    skidimm::EstimatesWriter writer(output, bank.config, reader.has_truth());
    skidimm::LogSample sample;
    std::size_t k = 0;
    const double* numbers = recorded.numbers.data();
    while (reader.next(&sample)) {
      if (k == recorded.modes.size()) break;
      for (Eigen::Index j = 0; j < modes; ++j) e.mode_probabilities[j] = *numbers++;
      for (Eigen::Index i = 0; i < n; ++i) e.state[i] = *numbers++;
      for (Eigen::Index i = 0; i < n; ++i) e.covariance(i, i) = *numbers++;
      e.most_likely_mode = recorded.modes[k];
      e.status = recorded.statuses[k];
      writer.write(sample.t, e, names.name(recorded.decisions[k]), sample.truth_mode);
      ++k;
    }
    writer.commit();
    state.SetIterationTime(thread_cpu_seconds() - start);
    if (k != recorded.modes.size()) {
      state.SkipWithError("the log read again has another number of rows");
      return;
    }
  }
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["output_bytes"] = output_bytes(output);
}

void run_loop(benchmark::State& state, const std::string& bank_name) {
  const long rows = std::min<long>(benchmark_rows(), 200000);
  const std::filesystem::path log = long_log(example_of(bank_name), rows);
  const skidimm::Bank bank = bundled_bank(bank_name);
  const std::filesystem::path output = work_directory() / ("loop_" + bank_name + ".csv");
  long allocations = 0, total_rows = 0;
  for (auto _ : state) {
    skidimm::LogReader reader(bank.config, {log});
    skidimm::EstimatesWriter writer(output, bank.config, true);
    skidimm::RunSummary summary;
    // Counted from the 1024th row on: the Imm, its workspaces and the first
    // labels are set up before.
    long before = -1, rows_before = 0;
    skidimm::write_estimates(bank, &reader, {}, bank.config.decision, "", true, &writer, &summary, [&] {
      if (before >= 0) return;
      before = malloc_calls();
      rows_before = summary.rows;
    });
    allocations += malloc_calls() - before;
    total_rows += summary.rows - rows_before;
    writer.commit();
  }
  state.counters["rows"] = static_cast<double>(rows);
  state.counters["allocs_per_row"] = static_cast<double>(allocations) / static_cast<double>(total_rows);
}

void register_run_benchmarks() {
  for (const char* bank : {"ltc_terrains", "stc_slip16"}) {
    for (const char* extension : {".csv", ".npy"}) {
      const std::string name = std::string("Run/") + bank + (std::string(extension) == ".npy" ? "/npy" : "");
      benchmark::RegisterBenchmark(name.c_str(), [bank, extension](benchmark::State& s) {
        run_executable(s, bank, extension);
      })->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
      const std::string floor = std::string("RunFloor/") + bank + (std::string(extension) == ".npy" ? "/npy" : "");
      benchmark::RegisterBenchmark(floor.c_str(), [bank, extension](benchmark::State& s) {
        run_floor(s, bank, extension);
      })->UseManualTime()->Iterations(1)->Unit(benchmark::kMillisecond);
    }
    benchmark::RegisterBenchmark((std::string("RunLoop/") + bank).c_str(), [bank](benchmark::State& s) {
      run_loop(s, bank);
    })->Iterations(1)->Unit(benchmark::kMillisecond);
  }
}

const bool run_benchmarks_registered = (register_run_benchmarks(), true);

}  // namespace
}  // namespace skidimm_bench
