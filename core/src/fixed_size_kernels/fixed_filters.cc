// Kernel<FixedFilters<N, M>> for N states and M rows in 1..4 (fixed_size_kernels.h).
#include "fixed_size_kernels/factories.h"

namespace skidimm::internal {

template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<1, 1>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<1, 2>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<1, 3>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<1, 4>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<2, 1>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<2, 2>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<2, 3>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<2, 4>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<3, 1>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<3, 2>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<3, 3>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<3, 4>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<4, 1>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<4, 2>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<4, 3>(const Bank& bank);
template std::unique_ptr<ImmKernel> make_fixed_filters_kernel<4, 4>(const Bank& bank);

}  // namespace skidimm::internal
