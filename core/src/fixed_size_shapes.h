// Which bank shapes have a fixed-size IMM kernel compiled (fixed_size_kernels.h).
#pragma once

#include "skidimm/engine/imm.h"

namespace skidimm::internal {

// Each fixed shape is a compiled copy of the whole filter step. A build
// configured with SKIDIMM_FIXED_SIZE_KERNELS=bundled (CMakeLists.txt) compiles
// only the bundled banks' shapes, the engine in a third of the time, for
// builds where that matters more than speed (the sanitizer build); a bank of
// another shape then runs the dynamic kernel, which agrees to round-off.
#ifdef SKIDIMM_BUNDLED_FIXED_SIZE_KERNELS
inline constexpr bool kEveryFixedShape = false;
#else
inline constexpr bool kEveryFixedShape = true;
#endif

// FixedFilters<N, M>, N states and M rows, both at most 4; bundled: 2 x 2
// (LTC), 3 x 3 (STC), 4 x 4 (BorealTC's wheels).
constexpr bool compiles_fixed_filters(int n, int m) {
  return n >= 1 && n <= 4 && m >= 1 && m <= 4 && (kEveryFixedShape || (n == m && n >= 2));
}

// FixedStateFilters<N>, N states and any rows; bundled: 3 (stc_traction's
// outputs) and 9 (BorealTC).
constexpr bool compiles_fixed_states(int n) {
  return n >= 1 && n <= kMaxFixedStates && (kEveryFixedShape || n == 3 || n == 9);
}

// Whether Imm runs a bank of n states and m measurement rows on a fixed-size
// kernel when the fastest is chosen.
constexpr bool has_fixed_size_kernel(int n, int m) {
  return m >= 1 && (compiles_fixed_filters(n, m) || compiles_fixed_states(n));
}

}  // namespace skidimm::internal
