// The blocks of a symmetric matrix: groups of indices its nonzero entries
// couple. A covariance of parameters estimated from separate residuals (each
// feature's regression in linear_features) is block diagonal, and what is
// computed block by block keeps its exact zeros between blocks, which the
// filter then skips.
#ifndef SKIDIMM_CORE_SRC_COUPLED_BLOCKS_H_
#define SKIDIMM_CORE_SRC_COUPLED_BLOCKS_H_

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <vector>

namespace skidimm {

// The connected components of the graph whose edges are m's nonzero entries
// (m(a, b) or m(b, a)), each in increasing order, ordered by their first
// index. An index whose row and column are zero is a block of its own.
inline std::vector<std::vector<Eigen::Index>> coupled_blocks(const Eigen::MatrixXd& m) {
  const Eigen::Index q = m.rows();
  std::vector<char> placed(static_cast<std::size_t>(q), 0);
  std::vector<std::vector<Eigen::Index>> blocks;
  for (Eigen::Index start = 0; start < q; ++start) {
    if (placed[static_cast<std::size_t>(start)]) continue;
    std::vector<Eigen::Index> members{start}, todo{start};
    placed[static_cast<std::size_t>(start)] = 1;
    while (!todo.empty()) {
      const Eigen::Index a = todo.back();
      todo.pop_back();
      for (Eigen::Index b = 0; b < q; ++b) {
        if (!placed[static_cast<std::size_t>(b)] && (m(a, b) != 0.0 || m(b, a) != 0.0)) {
          placed[static_cast<std::size_t>(b)] = 1;
          members.push_back(b);
          todo.push_back(b);
        }
      }
    }
    std::sort(members.begin(), members.end());
    blocks.push_back(std::move(members));
  }
  return blocks;
}

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_COUPLED_BLOCKS_H_
