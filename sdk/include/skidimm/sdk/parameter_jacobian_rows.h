// The contract of MotionModel::parameter_jacobian_rows(), checked in one
// place: by the engine when a mode with parameter uncertainty is built, and
// by the conformance kit.
#ifndef SKIDIMM_SDK_PARAMETER_JACOBIAN_ROWS_H_
#define SKIDIMM_SDK_PARAMETER_JACOBIAN_ROWS_H_

#include <string>
#include <vector>

namespace skidimm {
namespace sdk {

// Why `rows` cannot be the parameter_jacobian_rows() of a model with
// `num_parameters` parameters and `num_states` states (one list per
// parameter, each increasing and within the states), as the end of a
// sentence that starts with "parameter_jacobian_rows() "; "" when they can.
// Empty `rows` (any row) always can.
inline std::string parameter_jacobian_rows_problem(const std::vector<std::vector<int>>& rows, int num_parameters,
                                                   int num_states) {
  if (rows.empty()) return "";
  if (rows.size() != static_cast<std::size_t>(num_parameters)) {
    return "lists " + std::to_string(rows.size()) + " parameters; the model has " + std::to_string(num_parameters);
  }
  for (std::size_t k = 0; k < rows.size(); ++k) {
    for (std::size_t i = 0; i < rows[k].size(); ++i) {
      const int row = rows[k][i];
      if (row < 0 || row >= num_states || (i > 0 && row <= rows[k][i - 1])) {
        return "for parameter " + std::to_string(k) + " are not increasing rows of its " + std::to_string(num_states) +
               " states";
      }
    }
  }
  return "";
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PARAMETER_JACOBIAN_ROWS_H_
