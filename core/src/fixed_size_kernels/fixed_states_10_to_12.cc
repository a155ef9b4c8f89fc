// Kernel<FixedStateFilters<N>> for N = 10..12 states (fixed_size_kernels.h).
#include "fixed_size_kernels/factories.h"

namespace skidimm::internal {

template std::unique_ptr<ImmKernel> make_fixed_state_kernel<10>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<11>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<12>(const Bank& bank);

}  // namespace skidimm::internal

static_assert(skidimm::kMaxFixedStates == 12,
              "fixed_size_kernels/fixed_states_*.cc instantiate make_fixed_state_kernel for N = 1..12");
