// Layout: the shapes of a function model whose states, inputs and parameter
// shapes come from the bank instead of the spec's constants.
//
// Most models know their shapes when they are compiled, and their spec says
// so with kStates, kInputs and the shapes in kParameters (function_model.h).
// A model that is written in the bank file itself (the bundled
// `linear_features`: dx/dt = A x + B u + c over the bank's own states and
// inputs, A full or diagonal as the bank writes it) learns them when a bank
// creates it. Its spec declares, instead of kStates and kInputs,
//
//   static constexpr int kMaxStates = 12, kMaxInputs = 16, kMaxParameters = ...;  // stack bounds
//   static bool layout(const skidimm::sdk::ParameterSet& params, skidimm::sdk::Layout* layout,
//                      std::string* error);
//
// and FunctionModel<Spec> is then generated for the shapes layout() reads
// from the mode's params (bank_shaped_function_model.h). Its table rows are
// BankShape or TextList (parameter_spec.h); layout() finds the Layout's
// states, inputs and angles filled from the bank, and says for each row of
// the table whether the bank gives it, in which shape and whether it is
// held fixed. Everything else (the checks of the bank's names, unknown keys,
// reading the values and naming a non-finite entry, the flat parameter
// vector, PluginInfo, angle wrapping, the exception boundary) is the SDK's,
// as for any function model.
#ifndef SKIDIMM_SDK_BANK_LAYOUT_H_
#define SKIDIMM_SDK_BANK_LAYOUT_H_

#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "skidimm/sdk/parameter_spec.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace sdk {

// One row of the spec's table, as one model has it.
struct ParameterLayout {
  Shape shape{0, 0};  // rows x cols; 0 x 0: the bank does not give it (an optional key, or text)
  // Flat names "c[i]" (a list in the bank) instead of "c[i,0]": the names a
  // fitted bank is regrouped by, so it keeps the form the user wrote.
  bool is_list = false;
  // Held at the bank's values: still in the spec's p, but not one of the
  // model's parameters, so fitting leaves it alone (as Ceres leaves a
  // constant parameter block).
  bool fixed = false;
  // One per entry, row-major, for parameter_info(); empty: the table's.
  std::vector<std::string> descriptions;
  // Where its first entry is in the spec's p (set by the SDK after layout()).
  int offset = 0;

  int size() const { return shape.rows * shape.cols; }
  bool present() const { return size() > 0; }
};

struct Layout {
  // The bank's, in its order.
  std::vector<std::string> states;
  std::vector<bool> angles;
  std::vector<std::string> inputs;
  // One per row of the spec's kParameters, in its order.
  std::vector<ParameterLayout> parameters;

  int num_states() const { return static_cast<int>(states.size()); }
  int num_inputs() const { return static_cast<int>(inputs.size()); }
  // The length of the spec's p: every numeric entry the bank gives, fixed ones too.
  int num_entries() const {
    int count = 0;
    for (const ParameterLayout& row : parameters) count += row.present() ? row.size() : 0;
    return count;
  }
  const ParameterLayout& operator[](int row) const { return parameters[static_cast<std::size_t>(row)]; }
  ParameterLayout& operator[](int row) { return parameters[static_cast<std::size_t>(row)]; }
};

namespace internal {

// Whether the spec takes its shapes from the bank: it has layout().
template <typename Spec, typename = void>
struct HasLayout : std::false_type {};
template <typename Spec>
struct HasLayout<Spec, std::void_t<decltype(Spec::layout(std::declval<const ParameterSet&>(), std::declval<Layout*>(),
                                                         std::declval<std::string*>()))>> : std::true_type {};

// Which FunctionModel a spec gets.
struct CompileTimeShapes {};
struct BankShapes {};
template <typename Spec>
using ShapesOf = std::conditional_t<HasLayout<Spec>::value, BankShapes, CompileTimeShapes>;

}  // namespace internal

// The model generated from a spec (function_model.h for compile-time shapes,
// bank_shaped_function_model.h for a spec with layout()). Declared here so
// that the conformance kit can name it without the jets' headers.
template <typename Spec, typename Shapes = internal::ShapesOf<Spec>>
class FunctionModel;

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_BANK_LAYOUT_H_
