#include "skidimm/fitting/trajectory.h"

#include "skidimm/log_io.h"

namespace skidimm {
namespace fitting {

Trajectory load_trajectory(const BankConfig& bank, const std::vector<std::filesystem::path>& files) {
  LogReader reader(bank, files);
  Trajectory trajectory;
  for (const auto& f : files) trajectory.source += (trajectory.source.empty() ? "" : "+") + f.string();
  std::vector<Eigen::VectorXd> inputs, measurements;
  LogSample sample;
  while (reader.next(&sample)) {
    trajectory.t.push_back(sample.t);
    inputs.push_back(sample.u);
    measurements.push_back(sample.z);
  }
  const int n = trajectory.size();
  trajectory.u.resize(bank.input_dim(), n);
  trajectory.z.resize(static_cast<Eigen::Index>(bank.measurement.names.size()), n);
  for (int k = 0; k < n; ++k) {
    trajectory.u.col(k) = inputs[k];
    trajectory.z.col(k) = measurements[k];
  }
  return trajectory;
}

}  // namespace fitting
}  // namespace skidimm
