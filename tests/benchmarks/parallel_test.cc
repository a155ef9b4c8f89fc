// eval and fit over many logs spread them over the cores (parallel.h); the
// results, their order and their errors must be those of one thread.
#include "parallel.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/temp_files.h"

extern char** environ;

namespace skidimm {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;

TEST(ParallelFor, EveryIndexRunsOnceWithItsWorkersIndex) {
  for (int workers : {1, 2, 5}) {
    std::vector<std::atomic<int>> runs(1000);
    std::atomic<bool> bad_worker{false};
    parallel_for(1000, workers, [&](int i, int worker) {
      ++runs[static_cast<std::size_t>(i)];
      if (worker < 0 || worker >= workers) bad_worker = true;
    });
    for (const auto& r : runs) ASSERT_EQ(r.load(), 1);
    EXPECT_FALSE(bad_worker);
  }
}

TEST(ParallelFor, TheLowestFailingIndexIsRethrownAsOneThreadWould) {
  for (int workers : {1, 2, 8}) {
    std::atomic<int> started_past{0};
    try {
      parallel_for(200, workers, [&](int i, int) {
        if (i > 150) ++started_past;
        if (i == 17 || i == 90) throw std::runtime_error("job " + std::to_string(i));
      });
      ADD_FAILURE() << "expected an error";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "job 17") << workers << " workers";
    }
    EXPECT_LT(started_past.load(), 50) << "jobs past a failure are not started";
  }
}

// Runs the skidimm executable with SKIDIMM_THREADS=threads; returns stdout.
std::string run_skidimm(const std::vector<std::string>& arguments, int threads, const std::filesystem::path& dir,
                        int* status) {
  const std::filesystem::path out = dir / ("stdout_" + std::to_string(threads) + ".txt");
  std::vector<std::string> args{SKIDIMM_EXECUTABLE};
  args.insert(args.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> environment{"SKIDIMM_THREADS=" + std::to_string(threads)};
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::string(*e).rfind("SKIDIMM_THREADS=", 0) != 0) environment.emplace_back(*e);
  }
  std::vector<char*> envp;
  for (std::string& e : environment) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, (out.string() + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data()), 0);
  posix_spawn_file_actions_destroy(&actions);
  waitpid(pid, status, 0);
  return read_file(out) + "\n--- stderr ---\n" + read_file(out.string() + ".err");
}

// The bundled example log cut into pieces: several logs of one recording.
std::filesystem::path pieces(const std::filesystem::path& dir, const std::string& example, int count) {
  const std::filesystem::path logs = dir / "logs";
  std::filesystem::create_directories(logs);
  std::ifstream in(std::filesystem::path(SKIDIMM_SOURCE_DIR) / "configs" / "examples" / (example + ".csv"));
  std::string header, line;
  std::getline(in, header);
  std::vector<std::string> rows;
  while (std::getline(in, line)) rows.push_back(line);
  const std::size_t per = rows.size() / static_cast<std::size_t>(count);
  for (int p = 0; p < count; ++p) {
    std::ofstream out(logs / ("piece" + std::to_string(p) + ".csv"));
    out << header << "\n";
    for (std::size_t r = p * per; r < (p + 1) * per; ++r) out << rows[r] << "\n";
  }
  return logs;
}

TEST(Threads, EvalGivesTheSameOutputOnOneThreadAndOnMany) {
  const auto dir = test_directory();
  const std::filesystem::path logs = pieces(dir, "stc_switching", 6);
  const std::string bank = std::string(SKIDIMM_SOURCE_DIR) + "/configs/stc_slip4.yaml";
  for (const std::vector<std::string>& arguments :
       {std::vector<std::string>{"eval", "--bank", bank, "--input", logs.string(), "--json"},
        std::vector<std::string>{"eval", "--bank", bank, "--input", (logs / "piece0.csv").string(), "--input",
                                 logs.string()},
        std::vector<std::string>{"eval", "--bank", bank, "--input", logs.string(), "--input", "no_such.csv"}}) {
    int status_one = 0, status_many = 0;
    const std::string one = run_skidimm(arguments, 1, dir, &status_one);
    const std::string many = run_skidimm(arguments, 4, dir, &status_many);
    EXPECT_EQ(status_one, status_many);
    EXPECT_EQ(one, many);
    EXPECT_NE(one.find(arguments.back() == "no_such.csv" ? "no_such.csv" : "accuracy"), std::string::npos) << one;
  }
}

TEST(Threads, FitGivesTheSameOutputOnOneThreadAndOnMany) {
  const auto dir = test_directory();
  const std::filesystem::path logs = pieces(dir, "ltc_switching", 5);
  std::vector<std::string> arguments{"fit", "--bank", std::string(SKIDIMM_SOURCE_DIR) + "/configs/ltc_terrains.yaml",
                                     "--mode", "asphalt", "--objective", "window"};
  for (int p = 0; p < 4; ++p) {
    arguments.push_back("--log");
    arguments.push_back("asphalt=" + (logs / ("piece" + std::to_string(p) + ".csv")).string());
  }
  arguments.push_back("--held-out");
  arguments.push_back("asphalt=" + (logs / "piece4.csv").string());
  int status_one = 0, status_many = 0;
  const std::string one = run_skidimm(arguments, 1, dir, &status_one);
  const std::string many = run_skidimm(arguments, 4, dir, &status_many);
  EXPECT_EQ(status_one, 0);
  EXPECT_EQ(status_many, 0);
  EXPECT_EQ(one, many);
  EXPECT_NE(one.find("held out"), std::string::npos) << one;
}

}  // namespace
}  // namespace skidimm
