#include "measured_outputs.h"

#include <algorithm>
#include <cmath>

#include "skidimm/errors.h"

namespace skidimm {

std::vector<int> output_indices(const sdk::MotionModel& model, const std::vector<std::string>& measured) {
  const std::vector<std::string>& names = model.output_names();
  std::vector<int> indices;
  for (const std::string& output : measured) {
    const auto at = std::find(names.begin(), names.end(), output);
    indices.push_back(at == names.end() ? -1 : static_cast<int>(at - names.begin()));
  }
  return indices;
}

MeasuredOutputs::MeasuredOutputs(const Bank& bank) {
  const MeasurementConfig& measurement = bank.config.measurement;
  first_row_ = measurement.first_output_row();
  num_outputs_ = static_cast<int>(measurement.outputs.size());
  const Eigen::Index rows = measurement.h.rows();
  for (std::size_t j = 0; j < bank.models.size(); ++j) {
    const sdk::MotionModel& model = *bank.models[j];
    std::vector<int> index = output_indices(model, measurement.outputs);
    for (std::size_t k = 0; k < index.size(); ++k) {
      if (index[k] < 0) {
        throw Error("mode '" + bank.config.modes[j].name + "' (model " + bank.config.modes[j].model +
                    ") has no output '" + measurement.outputs[k] + "', which the bank measures");
      }
    }
    models_.push_back(&model);
    index_.push_back(std::move(index));
    model_outputs_.emplace_back(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model.output_names().size())));
    expected_.emplace_back(Eigen::VectorXd::Zero(rows));
  }
}

bool MeasuredOutputs::measured(const Eigen::Ref<const Eigen::VectorXd>& z) const {
  for (int k = 0; k < num_outputs_; ++k) {
    if (std::isfinite(z[first_row_ + k])) return true;
  }
  return false;
}

bool MeasuredOutputs::predict(int j, const Eigen::Ref<const Eigen::VectorXd>& u, std::string* reason) {
  const std::size_t m = static_cast<std::size_t>(j);
  Eigen::VectorXd& all = model_outputs_[m];
  if (!models_[m]->outputs(u, all)) {
    const char* why = models_[m]->failure_reason();
    if (reason != nullptr) {
      *reason = why != nullptr && why[0] != '\0' ? why : "outputs() returned false without a reason";
    }
    return false;
  }
  Eigen::VectorXd& expected = expected_[m];
  for (int k = 0; k < num_outputs_; ++k) {
    const double value = all[index_[m][static_cast<std::size_t>(k)]];
    if (!std::isfinite(value)) {
      if (reason != nullptr) *reason = "outputs() gave a value that is not finite";
      return false;
    }
    expected[first_row_ + k] = value;
  }
  return true;
}

}  // namespace skidimm
