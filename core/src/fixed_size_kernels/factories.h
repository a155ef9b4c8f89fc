// The definitions of fixed_size_kernels.h's factories, for the translation
// units of this directory, which instantiate them a few shapes each. Not for
// imm.cc: there the declarations alone keep every kernel out of its compile.
#ifndef SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_FACTORIES_H_
#define SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_FACTORIES_H_

#include <memory>

#include "fixed_size_kernels.h"
#include "fixed_size_shapes.h"
#include "imm_kernel.h"

namespace skidimm::internal {

template <int N, int M>
std::unique_ptr<ImmKernel> make_fixed_filters_kernel(const Bank& bank) {
  if constexpr (compiles_fixed_filters(N, M)) {
    return std::make_unique<Kernel<FixedFilters<N, M>>>(bank);
  } else {
    return nullptr;
  }
}

template <int N>
std::unique_ptr<ImmKernel> make_fixed_state_kernel(const Bank& bank) {
  if constexpr (compiles_fixed_states(N)) {
    return std::make_unique<Kernel<FixedStateFilters<N>>>(bank);
  } else {
    return nullptr;
  }
}

}  // namespace skidimm::internal

#endif  // SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_FACTORIES_H_
