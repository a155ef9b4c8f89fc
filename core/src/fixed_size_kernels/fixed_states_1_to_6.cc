// Kernel<FixedStateFilters<N>> for N = 1..6 states (fixed_size_kernels.h).
#include "fixed_size_kernels/factories.h"

namespace skidimm::internal {

template std::unique_ptr<ImmKernel> make_fixed_state_kernel<1>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<2>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<3>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<4>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<5>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_state_kernel<6>(const Bank& bank);

}  // namespace skidimm::internal
