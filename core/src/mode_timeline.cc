#include "skidimm/engine/mode_timeline.h"

#include <algorithm>
#include <cstdio>

#include "skidimm/time_origin.h"

namespace skidimm {

void ModeTimeline::add(double t, int most_likely_mode, double probability) {
  ++steps_;
  if (intervals_.empty() || intervals_.back().mode != most_likely_mode) {
    intervals_.push_back(ModeInterval{most_likely_mode, t, t, 0, 0.0});
  }
  ModeInterval& current = intervals_.back();
  current.end = t;
  ++current.steps;
  current.mean_probability += (probability - current.mean_probability) / static_cast<double>(current.steps);
}

long ModeTimeline::changes() const {
  long changes = 0;
  int last = kTie;
  for (const ModeInterval& interval : intervals_) {
    if (interval.mode == kTie) continue;
    if (last != kTie && interval.mode != last) ++changes;
    last = interval.mode;
  }
  return changes;
}

double ModeTimeline::origin() const { return intervals_.empty() ? 0.0 : time_origin(intervals_.front().start); }

std::string ModeTimeline::format(const std::vector<std::string>& mode_names, std::size_t max_rows) const {
  static const std::string kTieName = "(a tie)";
  std::size_t width = kTieName.size();
  for (const std::string& name : mode_names) width = std::max(width, name.size());
  const double from = origin();
  auto row = [&](const ModeInterval& interval) {
    char buffer[512];
    const std::string& name = interval.mode == kTie ? kTieName : mode_names.at(static_cast<std::size_t>(interval.mode));
    std::snprintf(buffer, sizeof(buffer), "  %10.3f - %10.3f s  %-*s  (%ld steps, mean p = %.3f)\n",
                  interval.start - from, interval.end - from, static_cast<int>(width), name.c_str(), interval.steps,
                  interval.mean_probability);
    return std::string(buffer);
  };
  std::string out;
  const std::size_t n = intervals_.size();
  max_rows = std::max<std::size_t>(max_rows, 2);
  if (n <= max_rows) {
    for (const ModeInterval& interval : intervals_) out += row(interval);
    return out;
  }
  const std::size_t head = max_rows / 2;
  const std::size_t tail = max_rows - head;
  for (std::size_t i = 0; i < head; ++i) out += row(intervals_[i]);
  out += "  ... " + std::to_string(n - head - tail) + " more intervals ...\n";
  for (std::size_t i = n - tail; i < n; ++i) out += row(intervals_[i]);
  return out;
}

}  // namespace skidimm
