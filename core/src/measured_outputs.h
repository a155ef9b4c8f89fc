// MeasuredOutputs: what each mode of a bank predicts for the model outputs
// the bank measures (`measurement.outputs`, sdk::MotionModel::outputs()).
//
// An output depends on the input alone, so its row of H is zero and mode j's
// filter is updated with z - expected(j): on an output row the innovation is
// the measured output minus the mode's prediction, with S = R there, and no
// state moves. The likelihood then compares the modes on how well each
// predicts the output (a yaw rate, a motor current) besides the state rows.
// After construction nothing allocates.
#ifndef SKIDIMM_CORE_SRC_MEASURED_OUTPUTS_H_
#define SKIDIMM_CORE_SRC_MEASURED_OUTPUTS_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {

// Where each name of `measured` is in model.output_names(); -1 where the
// model has no such output.
std::vector<int> output_indices(const sdk::MotionModel& model, const std::vector<std::string>& measured);

class MeasuredOutputs {
 public:
  // Throws Error naming the mode and output when a mode's model lacks an
  // output the bank measures (Bank::load checks this with the file's line).
  explicit MeasuredOutputs(const Bank& bank);

  // Whether the bank measures any output.
  bool any() const { return num_outputs_ > 0; }
  int first_row() const { return first_row_; }
  int num_outputs() const { return num_outputs_; }
  // Whether z measures some output at this step.
  bool measured(const Eigen::Ref<const Eigen::VectorXd>& z) const;

  // Computes what mode j predicts for input u into expected(j). False if the
  // model's outputs() fails or gives a value that is not finite; *reason
  // then says which.
  bool predict(int j, const Eigen::Ref<const Eigen::VectorXd>& u, std::string* reason);
  // Full measurement size: 0 on the state rows, the last prediction on the
  // output rows.
  const Eigen::VectorXd& expected(int j) const { return expected_[static_cast<std::size_t>(j)]; }

 private:
  int first_row_ = 0;
  int num_outputs_ = 0;
  std::vector<const sdk::MotionModel*> models_;
  std::vector<std::vector<int>> index_;         // per mode: each measured output's index in outputs()
  std::vector<Eigen::VectorXd> model_outputs_;  // per mode: all of its model's outputs
  std::vector<Eigen::VectorXd> expected_;       // per mode: measurement-sized
};

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_MEASURED_OUTPUTS_H_
