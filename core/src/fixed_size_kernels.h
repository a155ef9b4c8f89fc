// The IMM's fixed-size kernels (imm_kernel.h), one compiled copy of the whole
// filter step per bank shape (fixed_size_shapes.h), made by the factories
// below and chosen by imm.cc.
//
// Each instantiation is defined in one of the translation units under
// fixed_size_kernels/, a few shapes each, as Ceres compiles its Schur
// eliminator's specializations. Together they are the largest part of the
// library's compile: in one unit with imm.cc they were a single 4.4 GB,
// ten-minute compile that the rest of a two-core build waited on, and apart
// a build spreads them over its cores.
#ifndef SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_H_
#define SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_H_

#include <memory>

namespace skidimm {
struct Bank;

namespace internal {
class ImmKernel;

// Kernel<FixedFilters<N, M>>: N states and M measurement rows, both in 1..4
// (fixed_size_kernels/fixed_filters.cc); null when this build does not
// compile the shape (compiles_fixed_filters()).
template <int N, int M>
std::unique_ptr<ImmKernel> make_fixed_filters_kernel(const Bank& bank);

// Kernel<FixedStateFilters<N>>: N states in 1..kMaxFixedStates, any rows
// (fixed_size_kernels/fixed_states_*.cc); null when this build does not
// compile the shape (compiles_fixed_states()).
template <int N>
std::unique_ptr<ImmKernel> make_fixed_state_kernel(const Bank& bank);

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FIXED_SIZE_KERNELS_H_
