// The thread-safety claims of imm.h, bank.h, plugin_registry.h and live_log.h
// (docs/engine.md, "Thread safety"), each pinned by a test. They pass in any
// build; built with ThreadSanitizer (scripts/check.sh --tsan) a data race in
// any of them fails the run. Each compares what the threads computed with the
// same work done on one thread, so a race that corrupts results without
// being caught still fails.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/io/live_log.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace {

namespace fs = std::filesystem;

const fs::path kSource = SKIDIMM_SOURCE_DIR;

struct Job {
  fs::path bank;
  fs::path log;
};

const Job kLtc{kSource / "configs/ltc_terrains.yaml", kSource / "configs/examples/ltc_switching.csv"};
const Job kStc{kSource / "configs/stc_slip4.yaml", kSource / "configs/examples/stc_switching.csv"};

// The mode probabilities and states of every step of `log`, run by `imm`.
std::vector<double> run(Imm& imm, const fs::path& log) {
  std::vector<double> out;
  LogReader reader(imm.config(), {log});
  LogSample sample;
  while (reader.next(&sample)) {
    const ImmEstimate& e = imm.step(sample.t, sample.u, sample.z);
    out.insert(out.end(), e.mode_probabilities.data(), e.mode_probabilities.data() + e.mode_probabilities.size());
    out.insert(out.end(), e.state.data(), e.state.data() + e.state.size());
  }
  return out;
}

std::vector<double> run_alone(const Job& job) {
  Imm imm = Imm::from_yaml(job.bank, {SKIDIMM_PLUGIN_DIR});
  return run(imm, job.log);
}

// imm.h: separate Imms on separate threads, each loading its own bank (and
// plugins) at the same time as the others.
TEST(ThreadSafety, SeparateImmsRunOnSeparateThreads) {
  const std::vector<Job> jobs = {kLtc, kStc, kLtc, kStc};
  std::vector<std::vector<double>> expected;
  for (const Job& job : jobs) expected.push_back(run_alone(job));
  std::vector<std::vector<double>> results(jobs.size());
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    threads.emplace_back([&, i] { results[i] = run_alone(jobs[i]); });
  }
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    ASSERT_FALSE(expected[i].empty());
    EXPECT_EQ(results[i], expected[i]) << jobs[i].bank;
  }
}

// imm.h and motion_model.h: Imms made from copies of one Bank share its model
// instances (the copies hold the same ModelHandles) and may run on separate
// threads: the engine calls only a model's const members, which the SDK
// requires to be safe to call concurrently (stc_kinematic's per-thread cache
// is exercised here).
TEST(ThreadSafety, ImmsSharingModelsRunOnSeparateThreads) {
  for (const Job& job : {kLtc, kStc}) {
    const Bank bank = Bank::load(job.bank, {SKIDIMM_PLUGIN_DIR});
    const std::vector<double> expected = run_alone(job);
    std::vector<std::vector<double>> results(3);
    std::vector<std::thread> threads;
    for (std::size_t i = 0; i < results.size(); ++i) {
      threads.emplace_back([&, i] {
        Imm imm(bank);  // a copy of the bank: same models
        results[i] = run(imm, job.log);
      });
    }
    for (std::thread& t : threads) t.join();
    for (const std::vector<double>& r : results) EXPECT_EQ(r, expected) << job.bank;
    EXPECT_GE(bank.models.front().use_count(), 1);
  }
}

// bank.h and plugin_registry.h: Bank::load may run on several threads at once
// (each call has its own PluginRegistry); one PluginRegistry is used by one
// thread at a time, and registries on different threads are independent.
TEST(ThreadSafety, BanksLoadConcurrently) {
  const std::vector<fs::path> banks = {kSource / "configs/ltc_terrains.yaml", kSource / "configs/stc_slip4.yaml",
                                       kSource / "configs/stc_sided4.yaml", kSource / "configs/ltc_shared.yaml"};
  std::vector<int> modes(banks.size() * 3, -1);
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < modes.size(); ++i) {
    threads.emplace_back([&, i] {
      const fs::path& file = banks[i % banks.size()];
      if (i % 2 == 0) {
        modes[i] = static_cast<int>(Bank::load(file, {SKIDIMM_PLUGIN_DIR}).models.size());
      } else {
        PluginRegistry registry({SKIDIMM_PLUGIN_DIR});  // this thread's own
        modes[i] = static_cast<int>(Bank::instantiate(load_bank_config(file), registry).models.size());
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < modes.size(); ++i) {
    EXPECT_EQ(modes[i], load_bank_config(banks[i % banks.size()]).num_modes()) << banks[i % banks.size()];
  }
}

// Whether the plugin is mapped into this process: the registry loads a
// private copy (a memfd named after the file, sdk/private_library.h) or, as a
// fallback, the file itself; either shows in /proc/self/maps by file name.
bool library_loaded(const std::string& file) {
  std::ifstream maps("/proc/self/maps");
  const std::string name = fs::path(file).filename().string();
  std::string line;
  while (std::getline(maps, line)) {
    if (line.find(name) != std::string::npos) return true;
  }
  return false;
}

// plugin_registry.h: a plugin library is unloaded only when the registry that
// loaded it and every model created from it are gone, on whichever thread
// releases the last of them; a model keeps working on another thread after
// its registry is destroyed.
TEST(ThreadSafety, APluginIsUnloadedOnlyAfterItsLastModelOnAnyThread) {
  const std::string file = SKIDIMM_LTC_LINEAR_PLUGIN;
  ASSERT_FALSE(library_loaded(file)) << "loaded before the test: the test cannot see the unload";
  Bank bank = Bank::load(kSource / "configs/ltc_terrains.yaml", {SKIDIMM_PLUGIN_DIR});
  ASSERT_EQ(bank.model_sources.front().file, fs::path(file));
  ModelHandle model = bank.models.front();
  EXPECT_TRUE(library_loaded(file));
  std::vector<double> predicted;
  {
    std::thread worker([model = std::move(model), &predicted]() mutable {
      Eigen::VectorXd x(2), u(2), next(2);
      x << 0.8, -0.3;
      u << 3.0, 6.5;
      for (int k = 0; k < 200; ++k) {
        if (!model->predict(x, u, 0.02, next)) return;
        x = next;
      }
      predicted.assign(x.data(), x.data() + x.size());
      model.reset();  // maybe the last reference: the library would unload here, on this thread
    });
    // Meanwhile the bank (and with it the other models) goes away on this one.
    bank = Bank();
    worker.join();
  }
  ASSERT_EQ(predicted.size(), 2u);
  EXPECT_TRUE(std::isfinite(predicted[0]) && std::isfinite(predicted[1]));
  EXPECT_FALSE(library_loaded(file)) << "still loaded after its last model was released";
}

// live_log.h: the program's thread pushes rows and takes steps while the
// reader's thread reads them; the steps, run by an Imm, give what the log
// read from its file gives.
TEST(ThreadSafety, ALiveLogsReaderWorksOnItsOwnThread) {
  Imm imm = Imm::from_yaml(kLtc.bank, {SKIDIMM_PLUGIN_DIR});
  const std::vector<double> expected = run(imm, kLtc.log);
  // The example log's wheel speeds and its odometry, as two sensors' rows.
  std::ifstream in(kLtc.log);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> wheels, odometry;
  while (std::getline(in, line)) {
    std::vector<double> cells;
    std::size_t from = 0;
    for (int c = 0; c < 5; ++c) {
      const std::size_t comma = line.find(',', from);
      cells.push_back(std::stod(line.substr(from, comma - from)));
      from = comma + 1;
    }
    wheels.push_back({cells[0], cells[1], cells[2]});
    odometry.push_back({cells[0], cells[3], cells[4]});
  }
  LiveLog live(imm.config(), {{"wheels", {"t", "phi_dot_L", "phi_dot_R"}}, {"odometry", {"t", "V", "omega"}}});
  imm.reset();
  std::vector<double> out;
  const auto step_all = [&] {
    for (LogSample s; live.next(&s);) {
      const ImmEstimate& e = imm.step(s.t, s.u, s.z);
      out.insert(out.end(), e.mode_probabilities.data(), e.mode_probabilities.data() + e.mode_probabilities.size());
      out.insert(out.end(), e.state.data(), e.state.data() + e.state.size());
    }
  };
  for (std::size_t k = 0; k < wheels.size(); ++k) {
    live.push(1, odometry[k]);
    live.push(0, wheels[k]);
    if (k % 3 == 0) step_all();
  }
  live.close();
  step_all();
  ASSERT_FALSE(expected.empty());
  EXPECT_EQ(out, expected);
}

}  // namespace
}  // namespace skidimm
