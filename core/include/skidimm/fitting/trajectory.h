// A log loaded whole for fitting: the filter's steps (log_reader.h) with
// their times, inputs and measurements in the bank's order, missing
// measurements as NaN, and the truth label of every step.
#ifndef SKIDIMM_FITTING_TRAJECTORY_H_
#define SKIDIMM_FITTING_TRAJECTORY_H_

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace fitting {

struct Trajectory {
  std::string source;              // file names, for messages (a segment's with its time span)
  std::string log;                 // the log it was read from: its files' paths joined by '+'
  std::vector<double> t;           // s, strictly increasing
  Eigen::MatrixXd u;               // input_dim x N
  Eigen::MatrixXd z;               // measurement_dim x N, NaN = missing
  std::vector<std::string> truth;  // the truth column's label at each step ("" if none)
  // What the sampling's skip_gaps and skip_out_of_order left out of the log
  // (LogReader::skipped_by_options()), and the measurement values that were
  // not finite (a log of 0: missing, so fitted without); a segment carries
  // its log's.
  std::vector<std::string> skipped;
  // The whole log's steps and the seconds from its first to its last; a
  // segment carries its log's.
  long log_steps = 0;
  double log_seconds = 0.0;
  int size() const { return static_cast<int>(t.size()); }
};

// Reads a log with the bank's columns and the given sampling. Throws LogError.
Trajectory load_trajectory(const BankConfig& bank, const std::vector<LogFile>& files, const SamplingConfig& sampling);
Trajectory load_trajectory(const BankConfig& bank, const std::vector<LogFile>& files);

// The runs of consecutive steps with one truth label, each a trajectory of
// its own (source "<source>[t0-t1 s]"), with its label. Steps without a label
// are left out.
std::vector<std::pair<std::string, Trajectory>> split_by_truth(const Trajectory& trajectory);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_TRAJECTORY_H_
