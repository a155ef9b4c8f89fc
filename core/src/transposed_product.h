// c = P' x, the IMM's predicted mode probabilities from a transition matrix
// given or in closed form, summed in exactly the order Eigen's
// `P.transpose() * x` sums it: its row-major matrix-vector kernel
// (Eigen/src/Core/products/GeneralMatrixVector.h) keeps, for each entry, one
// running packet of consecutive products, adds the packet's lanes, then the
// products left over one by one, and adds the result to a zeroed
// destination. The numbers are the same to the bit (the order decides which
// of two modes with exactly tied probabilities comes first, and published
// results depend on it); what is saved is the product's dispatch, which at 3
// or 4 modes costs more than the arithmetic. Where the vector unit has half
// packets (AVX) or fuses multiply-adds, Eigen's kernel sums differently and
// the product itself is called. Private to the engine.
#ifndef SKIDIMM_CORE_SRC_TRANSPOSED_PRODUCT_H_
#define SKIDIMM_CORE_SRC_TRANSPOSED_PRODUCT_H_

#include <Eigen/Core>

namespace skidimm {
namespace internal {

// *out = p' x (p square, x and *out of its size; *out is not x). Allocates nothing.
inline void transposed_times(const Eigen::MatrixXd& p, const Eigen::VectorXd& x, Eigen::VectorXd* out) {
  // The sizes from packet_traits, not unpacket_traits<Packet>: a vector type
  // as a class template's argument loses its attributes (gcc's
  // -Wignored-attributes).
  using Traits = Eigen::internal::packet_traits<double>;
  using Packet = Traits::type;
  constexpr Eigen::Index kLanes = Traits::size;
  constexpr bool kOnePacketSize = !Traits::HasHalfPacket;
#ifdef __FMA__
  constexpr bool kFusedMultiplyAdd = true;
#else
  constexpr bool kFusedMultiplyAdd = false;
#endif
  if constexpr (!kOnePacketSize || kFusedMultiplyAdd || kLanes < 2) {
    out->noalias() = p.transpose() * x;
  } else {
    const Eigen::Index n = p.rows();
    const double* b = x.data();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double* a = p.col(i).data();  // row i of p'
      Packet sum = Eigen::internal::pset1<Packet>(0.0);
      Eigen::Index j = 0;
      for (; j + kLanes <= n; j += kLanes) {
        sum = Eigen::internal::pmadd(Eigen::internal::ploadu<Packet>(a + j), Eigen::internal::ploadu<Packet>(b + j),
                                     sum);
      }
      double entry = Eigen::internal::predux(sum);
      for (; j < n; ++j) entry += a[j] * b[j];
      double result = 0.0;
      result += entry;
      (*out)[i] = result;
    }
  }
}

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_TRANSPOSED_PRODUCT_H_
