#include "skidimm/progress.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

#include "core/temp_files.h"

namespace skidimm {
namespace {

TEST(Progress, DurationsAreWholeSecondsRoundedUp) {
  EXPECT_EQ(format_duration(0.0), "0:00");
  EXPECT_EQ(format_duration(-3.0), "0:00");
  EXPECT_EQ(format_duration(0.2), "0:01") << "some time left is never shown as none";
  EXPECT_EQ(format_duration(59.5), "1:00");
  EXPECT_EQ(format_duration(61.0), "1:01");
  EXPECT_EQ(format_duration(3600.0 + 62.0), "1:01:02");
}

// Each expected text computed by hand: rate = done / elapsed; time left =
// elapsed (1 - f) / f with f = fraction, else done / total.
TEST(Progress, RateAndTimeLeftFromCountsAndElapsedSeconds) {
  // 3000 rows in 2 s; a quarter of the log's bytes read: 2 * 0.75 / 0.25 = 6 s left.
  EXPECT_EQ(format_rate_and_time_left(3000, 0, 2.0, "rows", 0.25), "1500 rows/s, 0:06 left");
  // 3 of 10 in 4 s: 0.75/s; 4 * 0.7 / 0.3 = 9.33 s, rounded up.
  EXPECT_EQ(format_rate_and_time_left(3, 10, 4.0, "modes"), "0.75 modes/s, 0:10 left");
  // 100000 of 400000 in 50 s: 2000/s; 50 * 3 = 150 s.
  EXPECT_EQ(format_rate_and_time_left(100000, 400000, 50.0, "rows"), "2000 rows/s, 2:30 left");
  // 1 of 100 in 40 s: 0.025/s; 40 * 99 = 3960 s.
  EXPECT_EQ(format_rate_and_time_left(1, 100, 40.0, "folds"), "0.025 folds/s, 1:06:00 left");
  // All done: nothing left.
  EXPECT_EQ(format_rate_and_time_left(20, 20, 7.0, "modes"), "2.9 modes/s, 0:00 left");
  // No total: 12 in 3.5 s, and the time so far.
  EXPECT_EQ(format_rate_and_time_left(12, 0, 3.5, "iterations"), "3.4 iterations/s, 0:04 so far");
  // Nothing to say yet.
  EXPECT_EQ(format_rate_and_time_left(0, 10, 5.0, "modes"), "");
  EXPECT_EQ(format_rate_and_time_left(5, 10, 0.0, "modes"), "");
  EXPECT_EQ(format_rate_and_time_left(1, 300, 0.2, "iterations"), "") << "a rate over less than a second is noise";
  EXPECT_EQ(format_rate_and_time_left(4, 0, 1.0, "iterations"), "4 iterations/s, 0:01 so far");
}

// Whatever the caller asks, nothing reaches a stderr that is not a terminal.
TEST(Progress, NothingIsPrintedWhenStderrIsNotATerminal) {
  const std::string file = (skidimm_test::test_directory() / "stderr.txt").string();
  std::fflush(stderr);
  const int saved = dup(STDERR_FILENO);
  const int redirected = open(file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ASSERT_GE(redirected, 0);
  dup2(redirected, STDERR_FILENO);
  close(redirected);
  const bool terminal = stderr_is_terminal();
  bool enabled = true;
  {
    ProgressLine line("skidimm run", "rows", true);
    enabled = line.enabled();
    line.update(3000, 0, 0.25);
    line.update(6000, 12000, -1.0, "mode 'ice'");
  }
  std::fflush(stderr);
  dup2(saved, STDERR_FILENO);
  close(saved);
  EXPECT_FALSE(terminal);
  EXPECT_FALSE(enabled);
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), "");
}

}  // namespace
}  // namespace skidimm
