// ParameterSpec: one row of a function model's parameter table.
//
// The table is the one place a model's parameters are described: the key a
// bank gives them under (`params:` or `shared:`), a one-line description with
// units, the shape, the bounds of every entry and the scope. From it the SDK
// generates what the bank loader, the fitter and `skidimm plugins` need
// (function_model.h): the flat ParameterInfo entries with their bounds, the
// PluginInfo docs, the checks of Create.
//
//   static constexpr skidimm::sdk::ParameterSpec kParameters[] = {
//       {"k", "longitudinal efficiency (-)", 0.0, 2.0},                        // a number in [0, 2]
//       {"r", "wheel radius (m)", 1e-6, kInfinity, ParameterScope::kBank},     // under shared:
//       {"A", "state matrix (1/s)", Shape{2, 2}},                              // any finite 2x2
//       {"w", "weights (-)", Shape{3, 1}, 0.0, 1.0},                           // a list of 3 in [0, 1]
//   };
//
// The model's function sees the parameters as one flat array in table order,
// each matrix row-major: with the table above, p[0] = k, p[1] = r,
// p[2..5] = A, p[6..8] = w. parameter_offset(kParameters, "A") is 2, at
// compile time, so a spec can name its offsets instead of counting them.
// Flat names (what `skidimm fit` reports and a fitted bank regroups): "k"
// for a number, "A[r,c]" for a matrix entry, "w[i]" for a vector entry.
//
// A model whose shapes come from the bank (a spec with layout(),
// bank_layout.h) marks such rows with the text `skidimm plugins` shows for
// their shape, and may have rows of text, which its layout() reads and which
// never enter the flat vector:
//
//       {"B", "input matrix", BankShape{"n x m"}},                   // n states x m inputs
//       {"fixed", "keys held at their values", TextList{"text list, optional"}},
#ifndef SKIDIMM_SDK_PARAMETER_SPEC_H_
#define SKIDIMM_SDK_PARAMETER_SPEC_H_

#include <array>
#include <cstddef>
#include <limits>

#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace sdk {

inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

// rows x cols; a vector is n x 1, a number 1 x 1.
struct Shape {
  int rows = 1;
  int cols = 1;
};

// The shape of a parameter that the bank decides, as `skidimm plugins` writes it ("n x m").
struct BankShape {
  const char* text;
};
// A parameter that is a list of text (names), as `skidimm plugins` writes it ("text list, optional").
struct TextList {
  const char* text;
};

// Numbers of the row's compile-time shape, numbers the bank shapes, or text.
enum class ParameterKind { kNumbers, kBankShaped, kText };

struct ParameterSpec {
  const char* key = "";          // its key under params: (or shared:)
  const char* description = "";  // one line, with units
  double lower_bound = -kInfinity;
  double upper_bound = kInfinity;
  ParameterScope scope = ParameterScope::kMode;
  Shape shape{};
  ParameterKind kind = ParameterKind::kNumbers;
  const char* shape_text = nullptr;  // for kBankShaped and kText rows

  constexpr ParameterSpec() = default;
  // A number in [lower_bound, upper_bound].
  constexpr ParameterSpec(const char* key, const char* description, double lower_bound, double upper_bound,
                          ParameterScope scope = ParameterScope::kMode)
      : key(key), description(description), lower_bound(lower_bound), upper_bound(upper_bound), scope(scope) {}
  // A matrix (or vector) of any finite entries.
  constexpr ParameterSpec(const char* key, const char* description, Shape shape,
                          ParameterScope scope = ParameterScope::kMode)
      : key(key), description(description), scope(scope), shape(shape) {}
  // A matrix (or vector) whose every entry lies in [lower_bound, upper_bound].
  constexpr ParameterSpec(const char* key, const char* description, Shape shape, double lower_bound, double upper_bound,
                          ParameterScope scope = ParameterScope::kMode)
      : key(key),
        description(description),
        lower_bound(lower_bound),
        upper_bound(upper_bound),
        scope(scope),
        shape(shape) {}
  // Numbers whose shape the bank decides (the spec's layout()): no entries
  // of their own in the compile-time count.
  constexpr ParameterSpec(const char* key, const char* description, BankShape shape,
                          ParameterScope scope = ParameterScope::kMode)
      : key(key),
        description(description),
        scope(scope),
        shape{0, 0},
        kind(ParameterKind::kBankShaped),
        shape_text(shape.text) {}
  // Text, read by the spec's layout(); never a parameter to fit.
  constexpr ParameterSpec(const char* key, const char* description, TextList list,
                          ParameterScope scope = ParameterScope::kMode)
      : key(key),
        description(description),
        scope(scope),
        shape{0, 0},
        kind(ParameterKind::kText),
        shape_text(list.text) {}

  constexpr int size() const { return shape.rows * shape.cols; }
  constexpr bool is_scalar() const { return shape.rows == 1 && shape.cols == 1; }
  constexpr bool is_vector() const { return shape.cols == 1 && shape.rows > 1; }
};

namespace internal {

constexpr bool same_text(const char* a, const char* b) {
  while (*a != '\0' && *a == *b) ++a, ++b;
  return *a == *b;
}

// A throw in a constant expression is a compile error naming this function.
inline void unknown_parameter_key() {}

}  // namespace internal

// The number of doubles in the flat parameter vector of `table`.
template <typename Table>
constexpr int flat_parameter_count(const Table& table) {
  int count = 0;
  for (const ParameterSpec& p : table) count += p.size();
  return count;
}

// The offset of `key`'s first entry in the flat parameter vector of `table`.
// In a constant expression, a key the table lacks does not compile.
template <typename Table>
constexpr int parameter_offset(const Table& table, const char* key) {
  int offset = 0;
  for (const ParameterSpec& p : table) {
    if (internal::same_text(p.key, key)) return offset;
    offset += p.size();
  }
  internal::unknown_parameter_key();  // not constexpr: a missing key fails to compile
  return -1;
}

// Two tables one after the other: the table of a model that extends another
// (stc_traction's is stc_sided's and its own), written once.
template <std::size_t N, std::size_t M>
constexpr std::array<ParameterSpec, N + M> join_parameters(const ParameterSpec (&first)[N],
                                                           const ParameterSpec (&second)[M]) {
  std::array<ParameterSpec, N + M> joined{};
  for (std::size_t i = 0; i < N; ++i) joined[i] = first[i];
  for (std::size_t i = 0; i < M; ++i) joined[N + i] = second[i];
  return joined;
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PARAMETER_SPEC_H_
