#include "skidimm/progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <utility>

namespace skidimm {

std::string format_duration(double seconds) {
  const long total = seconds > 0.0 ? static_cast<long>(std::ceil(seconds)) : 0;
  char text[48];
  if (total >= 3600) {
    std::snprintf(text, sizeof(text), "%ld:%02ld:%02ld", total / 3600, total / 60 % 60, total % 60);
  } else {
    std::snprintf(text, sizeof(text), "%ld:%02ld", total / 60, total % 60);
  }
  return text;
}

std::string format_rate_and_time_left(long done, long total, double elapsed_seconds, const std::string& unit,
                                      double fraction) {
  if (!(elapsed_seconds >= kSettleSeconds) || done <= 0) return "";
  const double rate = static_cast<double>(done) / elapsed_seconds;
  char number[32];
  std::snprintf(number, sizeof(number), rate < 10.0 ? "%.2g" : "%.0f", rate);
  std::string text = std::string(number) + " " + unit + "/s, ";
  if (fraction < 0.0 && total > 0) fraction = static_cast<double>(done) / static_cast<double>(total);
  if (fraction > 0.0) {
    const double left = fraction >= 1.0 ? 0.0 : elapsed_seconds * (1.0 - fraction) / fraction;
    return text + format_duration(left) + " left";
  }
  return text + format_duration(elapsed_seconds) + " so far";
}

bool stderr_is_terminal() { return isatty(STDERR_FILENO) != 0; }

ProgressLine::ProgressLine(std::string label, std::string unit, bool enabled)
    : enabled_(enabled && stderr_is_terminal()),
      label_(std::move(label)),
      unit_(std::move(unit)),
      start_(std::chrono::steady_clock::now()) {}

ProgressLine::~ProgressLine() { clear(); }

void ProgressLine::restart() { start_ = std::chrono::steady_clock::now(); }

void ProgressLine::update(long done, long total, double fraction, const std::string& what) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ < std::chrono::milliseconds(200)) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (fraction < 0.0 && total > 0) fraction = static_cast<double>(done) / static_cast<double>(total);
  std::string line = label_ + ": ";
  if (!what.empty()) line += what + "  ";
  if (fraction >= 0.0) {
    char percent[16];
    std::snprintf(percent, sizeof(percent), "%5.1f%%  ", 100.0 * fraction);
    line += percent;
  }
  line += std::to_string(done) + (total > 0 ? "/" + std::to_string(total) : std::string()) + " " + unit_;
  const std::string rate = format_rate_and_time_left(done, total, elapsed, unit_, fraction);
  if (!rate.empty()) line += ", " + rate;
  // Clear to the end of the line: the previous text may have been longer.
  std::fprintf(stderr, "\r%s\033[K", line.c_str());
  std::fflush(stderr);
  shown_ = true;
}

void ProgressLine::clear() {
  if (shown_) std::fprintf(stderr, "\r\033[K");
  shown_ = false;
}

}  // namespace skidimm
