// A log loaded whole for fitting: times, inputs and measurements in the
// bank's order, with missing measurements as NaN.
#ifndef SKIDIMM_FITTING_TRAJECTORY_H_
#define SKIDIMM_FITTING_TRAJECTORY_H_

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/bank.h"

namespace skidimm {
namespace fitting {

struct Trajectory {
  std::string source;     // file names, for messages
  std::vector<double> t;  // s, strictly increasing
  Eigen::MatrixXd u;      // input_dim x N
  Eigen::MatrixXd z;      // measurement_dim x N, NaN = missing
  int size() const { return static_cast<int>(t.size()); }
};

// Reads a log (several files side by side) with the bank's columns.
// Throws LogError.
Trajectory load_trajectory(const BankConfig& bank, const std::vector<std::filesystem::path>& files);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_TRAJECTORY_H_
