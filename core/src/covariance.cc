#include "covariance.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

namespace skidimm {

bool check_covariance(const Eigen::MatrixXd& m, bool strict, std::string* why) {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (m.rows() != m.cols()) {
    return fail("not square (" + std::to_string(m.rows()) + "x" + std::to_string(m.cols()) + ")");
  }
  if (!m.allFinite()) return fail("has non-finite entries");
  const double scale = std::max(1e-300, m.cwiseAbs().maxCoeff());
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < m.cols(); ++j) {
      if (std::abs(m(i, j) - m(j, i)) > 1e-9 * scale) {
        std::ostringstream out;
        out << "not symmetric: (" << i << "," << j << ") = " << m(i, j) << " but (" << j << "," << i
            << ") = " << m(j, i);
        return fail(out.str());
      }
    }
  }
  if (m.size() == 0) return true;
  const Eigen::VectorXd eigenvalues = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues();
  const double smallest = eigenvalues.minCoeff();
  const double tolerance = 1e-12 * std::max(1.0, eigenvalues.cwiseAbs().maxCoeff());
  if (strict ? !(smallest > 0.0) : smallest < -tolerance) {
    std::ostringstream out;
    out << "not positive " << (strict ? "definite" : "semidefinite") << ": smallest eigenvalue " << smallest;
    return fail(out.str());
  }
  return true;
}

}  // namespace skidimm
