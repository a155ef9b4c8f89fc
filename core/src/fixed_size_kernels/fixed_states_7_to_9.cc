// Kernel<FixedStateFilters<N>> for N = 7..9 states (fixed_size_kernels.h).
#include "fixed_size_kernels/factories.h"

namespace skidimm::internal {

template std::unique_ptr<ImmKernel> make_fixed_state_kernel<7>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<8>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<9>(const Bank& bank);

}  // namespace skidimm::internal
