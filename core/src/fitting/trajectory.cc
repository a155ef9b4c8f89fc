#include "skidimm/fitting/trajectory.h"

#include <cmath>
#include <cstdio>
#include <string>

#include "skidimm/io/log_spec.h"

namespace skidimm {
namespace fitting {

Trajectory load_trajectory(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling) {
  LogReader reader(bank, files, sampling);
  Trajectory trajectory;
  trajectory.source = joined_paths(files);
  trajectory.log = trajectory.source;
  std::vector<Eigen::VectorXd> inputs, measurements;
  LogSample sample;
  while (reader.next(&sample)) {
    trajectory.t.push_back(sample.t);
    inputs.push_back(sample.u);
    measurements.push_back(sample.z);
    trajectory.truth.push_back(sample.truth_mode);
  }
  trajectory.skipped = reader.skipped_by_options();
  const LogStats& stats = reader.stats();
  for (std::size_t i = 0; i < stats.not_finite.size() && i < bank.measurement.names.size(); ++i) {
    if (stats.not_finite[i] == 0) continue;
    trajectory.skipped.push_back("measurement '" + bank.measurement.names[i] +
                                 "': " + std::to_string(stats.not_finite[i]) +
                                 " value(s) of its expression were not finite (the log of 0, say) and were left out "
                                 "of the fit as missing");
  }
  const int n = trajectory.size();
  trajectory.log_steps = n;
  trajectory.log_seconds = n > 1 ? trajectory.t.back() - trajectory.t.front() : 0.0;
  trajectory.u.resize(bank.input_dim(), n);
  trajectory.z.resize(static_cast<Eigen::Index>(bank.measurement.names.size()), n);
  for (int k = 0; k < n; ++k) {
    trajectory.u.col(k) = inputs[static_cast<std::size_t>(k)];
    trajectory.z.col(k) = measurements[static_cast<std::size_t>(k)];
  }
  return trajectory;
}

Trajectory load_trajectory(const BankConfig& bank, const std::vector<LogFile>& files) {
  return load_trajectory(bank, files, bank.sampling);
}

namespace {

// A time of a segment's span: six significant digits, and at least three
// decimals beyond the seconds, so that the spans of a log stamped in
// seconds since 1970 (1.7e9) still tell its segments apart.
std::string span_time(double t) {
  int digits = 6;
  for (double whole = std::abs(t); whole >= 1000.0 && digits < 17; whole /= 10.0) ++digits;
  char text[64];
  std::snprintf(text, sizeof(text), "%.*g", digits, t);
  return text;
}

}  // namespace

std::vector<std::pair<std::string, Trajectory>> split_by_truth(const Trajectory& trajectory) {
  std::vector<std::pair<std::string, Trajectory>> out;
  const int n = trajectory.size();
  int begin = 0;
  while (begin < n) {
    int end = begin + 1;
    while (end < n && trajectory.truth[static_cast<std::size_t>(end)] == trajectory.truth[static_cast<std::size_t>(begin)])
      ++end;
    const std::string& label = trajectory.truth[static_cast<std::size_t>(begin)];
    if (!label.empty()) {
      Trajectory part;
      part.source = trajectory.source + "[" + span_time(trajectory.t[static_cast<std::size_t>(begin)]) + "-" +
                    span_time(trajectory.t[static_cast<std::size_t>(end - 1)]) + " s]";
      part.log = trajectory.log;
      part.skipped = trajectory.skipped;
      part.log_steps = trajectory.log_steps;
      part.log_seconds = trajectory.log_seconds;
      part.t.assign(trajectory.t.begin() + begin, trajectory.t.begin() + end);
      part.u = trajectory.u.middleCols(begin, end - begin);
      part.z = trajectory.z.middleCols(begin, end - begin);
      part.truth.assign(trajectory.truth.begin() + begin, trajectory.truth.begin() + end);
      out.emplace_back(label, std::move(part));
    }
    begin = end;
  }
  return out;
}

}  // namespace fitting
}  // namespace skidimm
