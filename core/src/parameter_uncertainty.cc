#include "skidimm/engine/parameter_uncertainty.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "coupled_blocks.h"
#include "covariance.h"
#include "parameter_noise.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/parameter_jacobian_rows.h"

namespace skidimm {

namespace {

// The model it wraps with G Sigma G' added to process_noise(); everything
// else is the wrapped model's. Like any model it may be shared by filters on
// several threads: its buffers are per thread.
class ParameterUncertainModel final : public sdk::MotionModel {
  struct Block;  // of Sigma, below

 public:
  ParameterUncertainModel(ModelHandle model, Eigen::MatrixXd covariance)
      : model_(std::move(model)), covariance_(std::move(covariance)) {
    // Sigma's blocks (coupled_blocks.h); parameters with no variance (held
    // ones) add nothing and are left out.
    for (std::vector<Eigen::Index>& parameters : coupled_blocks(covariance_)) {
      Block block;
      block.parameters = std::move(parameters);
      block.sigma = covariance_(block.parameters, block.parameters);
      if (block.sigma.cwiseAbs().maxCoeff() == 0.0) continue;
      block.sigma_finite = block.sigma.allFinite();
      largest_block_ = std::max(largest_block_, static_cast<Eigen::Index>(block.parameters.size()));
      blocks_.push_back(std::move(block));
    }
    use_declared_rows();
  }

  const ModelHandle& wrapped() const { return model_; }
  const Eigen::MatrixXd& covariance() const { return covariance_; }

  int state_dim() const noexcept override { return model_->state_dim(); }
  int input_dim() const noexcept override { return model_->input_dim(); }
  const std::vector<std::string>& state_names() const noexcept override { return model_->state_names(); }
  const std::vector<std::string>& input_names() const noexcept override { return model_->input_names(); }
  bool is_angle(int state_index) const noexcept override { return model_->is_angle(state_index); }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return model_->parameter_info(); }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { model_->get_parameters(values); }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    return model_->set_parameters(values, error);
  }
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    own_failure() = nullptr;
    return model_->predict(x, u, dt, x_next);
  }
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    own_failure() = nullptr;
    return model_->jacobian(x, u, dt, jacobian);
  }
  bool has_analytic_jacobian() const noexcept override { return model_->has_analytic_jacobian(); }
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return model_->parameter_jacobian(x, u, dt, jacobian);
  }
  const std::vector<std::vector<int>>& parameter_jacobian_rows() const noexcept override {
    return model_->parameter_jacobian_rows();
  }
  bool parameter_jacobian_entries(const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                  Eigen::Ref<Eigen::VectorXd> entries) const noexcept override {
    return model_->parameter_jacobian_entries(x, u, dt, entries);
  }

  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    own_failure() = nullptr;
    return model_->process_noise(intensity, x, u, dt, noise) && add_parameter_noise(x, u, dt, noise);
  }

  // noise += G Sigma G' at (x, u, dt), G = d predict / d theta.
  bool add_parameter_noise(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                           double dt, Eigen::Ref<Eigen::MatrixXd> noise) const noexcept {
    try {
      if (declared_entries_ > 0) return add_declared_parameter_noise(x, u, dt, noise);
      // Sized once per thread: no allocation per step after the first.
      thread_local Eigen::MatrixXd g;
      thread_local Eigen::MatrixXd gathered;  // G_b's nonzero rows, one per column, at block b
      thread_local Eigen::MatrixXd sigma_g;   // Sigma_b G_b' at those rows
      thread_local std::vector<Eigen::Index> rows;
      thread_local std::vector<std::uint64_t> row_bits;
      const Eigen::Index n = noise.rows();
      g.resize(n, covariance_.rows());
      if (!model_->parameter_jacobian(x, u, dt, g)) {
        own_failure() = "parameter_covariance: the model's parameter_jacobian() failed";
        return false;
      }
      // G Sigma G' = sum over Sigma's blocks b of G_b Sigma_b G_b' (G_b: G's
      // columns of b), and of G_b only the rows with a nonzero entry count:
      // in linear_features with a diagonal A each block is one feature's
      // regression and moves that feature's state alone, so a block is one
      // row and a 4 x 4 product. Dense, the BorealTC bank's 10 modes spent
      // ten times a step's filtering on it. Those rows of G_b are gathered
      // into contiguous columns for add_block().
      gathered.resize(largest_block_, n);
      sigma_g.resize(largest_block_, n);
      rows.resize(static_cast<std::size_t>(n));
      row_bits.resize(static_cast<std::size_t>(n));
      const double* const g_of = g.data();
      std::uint64_t* const bits_of = row_bits.data();
      for (const Block& block : blocks_) {
        const Eigen::Index m = static_cast<Eigen::Index>(block.parameters.size());
        const Eigen::Index* const k_of = block.parameters.data();
        // Which rows of G_b are nonzero: the bits of their entries but the
        // sign, or-ed down the block's columns (as G is stored), without a
        // branch per entry.
        std::fill(bits_of, bits_of + n, std::uint64_t{0});
        for (Eigen::Index c = 0; c < m; ++c) {
          const double* column = g_of + k_of[c] * n;
          for (Eigen::Index i = 0; i < n; ++i) {
            std::uint64_t bits;
            std::memcpy(&bits, column + i, sizeof bits);
            bits_of[i] |= bits << 1;
          }
        }
        Eigen::Index count = 0;
        for (Eigen::Index i = 0; i < n; ++i) {
          if (bits_of[i] == 0) continue;
          for (Eigen::Index c = 0; c < m; ++c) gathered(c, count) = g_of[k_of[c] * n + i];
          rows[static_cast<std::size_t>(count++)] = i;
        }
        add_gathered(block, gathered, rows, count, &sigma_g, &noise);
      }
    } catch (...) {  // bad_alloc
      own_failure() = "parameter_covariance: out of memory";
      return false;
    }
    return true;
  }

  // add_parameter_noise() for a model that declares where its parameter
  // Jacobian can be nonzero (MotionModel::parameter_jacobian_rows()): only
  // those entries are asked for, and each block's rows are known beforehand.
  // A declared row whose entries are all zero at this step adds +0 to the
  // noise, which the scan of the dense Jacobian would have skipped: the same
  // sums otherwise, in the same order. The +0 can turn a -0 of the noise into
  // +0, no value; it would be NaN against a non-finite Sigma, which no wrapper
  // holds (a file's covariance and a fit's are checked finite when set).
  bool add_declared_parameter_noise(const Eigen::Ref<const Eigen::VectorXd>& x,
                                    const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                    Eigen::Ref<Eigen::MatrixXd> noise) const {
    thread_local Eigen::VectorXd entries;
    thread_local Eigen::MatrixXd gathered;
    thread_local Eigen::MatrixXd sigma_g;
    entries.resize(declared_entries_);
    if (!model_->parameter_jacobian_entries(x, u, dt, entries)) {
      own_failure() = "parameter_covariance: the model's parameter_jacobian_entries() failed";
      return false;
    }
    gathered.resize(largest_block_, largest_declared_rows_);
    sigma_g.resize(largest_block_, largest_declared_rows_);
    for (const Block& block : blocks_) {
      const Eigen::Index m = static_cast<Eigen::Index>(block.parameters.size());
      const Eigen::Index count = static_cast<Eigen::Index>(block.rows.size());
      const int* source = block.sources.data();
      for (Eigen::Index q = 0; q < count; ++q) {
        for (Eigen::Index c = 0; c < m; ++c, ++source) gathered(c, q) = *source >= 0 ? entries[*source] : 0.0;
      }
      add_gathered(block, gathered, block.rows, count, &sigma_g, &noise);
    }
    return true;
  }

  // Up to 4 parameters (one feature's regression on up to three inputs) at
  // compile time; larger blocks (features whose fits are coupled) at run time.
  static void add_gathered(const Block& block, const Eigen::MatrixXd& gathered, const std::vector<Eigen::Index>& rows,
                           Eigen::Index count, Eigen::MatrixXd* sigma_g, Eigen::Ref<Eigen::MatrixXd>* noise) {
    const Eigen::MatrixXd& sigma = block.sigma;
    switch (sigma.rows()) {
      case 1:
        add_block<1>(sigma, gathered, rows, count, sigma_g, noise);
        break;
      case 2:
        add_block<2>(sigma, gathered, rows, count, sigma_g, noise);
        break;
      case 3:
        add_block<3>(sigma, gathered, rows, count, sigma_g, noise);
        break;
      case 4:
        add_block<4>(sigma, gathered, rows, count, sigma_g, noise);
        break;
      default:
        if (!block.sigma_finite || !add_sparse_block(sigma, gathered, rows, count, sigma_g, noise)) {
          add_block<Eigen::Dynamic>(sigma, gathered, rows, count, sigma_g, noise);
        }
        break;
    }
  }

  // With the wrapped model's declared rows (checked: one list per parameter,
  // increasing, within the states), each block's rows (their union over its
  // parameters) and where each of its entries is in
  // parameter_jacobian_entries()' output. Without, the dense Jacobian.
  void use_declared_rows() {
    const std::vector<std::vector<int>>& declared = model_->parameter_jacobian_rows();
    if (declared.empty()) return;
    const std::string problem =
        sdk::parameter_jacobian_rows_problem(declared, static_cast<int>(covariance_.rows()), model_->state_dim());
    if (!problem.empty()) throw Error("the model's parameter_jacobian_rows() " + problem);
    std::vector<int> first(declared.size() + 1, 0);  // where each parameter's entries start
    for (std::size_t k = 0; k < declared.size(); ++k) {
      first[k + 1] = first[k] + static_cast<int>(declared[k].size());
    }
    for (Block& block : blocks_) {
      std::vector<int> rows;
      for (Eigen::Index k : block.parameters) {
        rows.insert(rows.end(), declared[static_cast<std::size_t>(k)].begin(),
                    declared[static_cast<std::size_t>(k)].end());
      }
      std::sort(rows.begin(), rows.end());
      rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
      for (int row : rows) {
        block.rows.push_back(row);
        for (Eigen::Index k : block.parameters) {
          const std::vector<int>& moved = declared[static_cast<std::size_t>(k)];
          const auto at = std::find(moved.begin(), moved.end(), row);
          block.sources.push_back(
              at == moved.end() ? -1 : first[static_cast<std::size_t>(k)] + static_cast<int>(at - moved.begin()));
        }
      }
      largest_declared_rows_ = std::max(largest_declared_rows_, static_cast<Eigen::Index>(block.rows.size()));
    }
    declared_entries_ = first.back();
  }

  // noise += G_b Sigma_b G_b' at the `count` rows of G_b in `rows`, whose
  // entries are the columns of `gathered`. Sigma_b G_b' is a sum of Sigma_b's
  // columns (contiguous, a few to a vector instruction) rather than of
  // entries found through the block's parameter indices, held in registers
  // where the block's size M is known at compile time and in *sigma_g
  // otherwise. Each entry's sum runs in increasing index order, as the dense
  // products take it: the same result to the bit.
  template <int M>
  static void add_block(const Eigen::MatrixXd& sigma, const Eigen::MatrixXd& gathered,
                        const std::vector<Eigen::Index>& rows, Eigen::Index count, Eigen::MatrixXd* sigma_g,
                        Eigen::Ref<Eigen::MatrixXd>* noise) {
    const Eigen::Index m = M == Eigen::Dynamic ? sigma.rows() : M;
    const auto add_row = [&](Eigen::Index r, auto&& column) {
      column.setZero();
      for (Eigen::Index c = 0; c < m; ++c) column += gathered(c, r) * sigma.col(c);
      const Eigen::Index i = rows[static_cast<std::size_t>(r)];
      for (Eigen::Index q = 0; q <= r; ++q) {
        const Eigen::Index j = rows[static_cast<std::size_t>(q)];
        double added = 0.0;
        for (Eigen::Index l = 0; l < m; ++l) added += column[l] * gathered(l, q);
        (*noise)(i, j) += added;
        if (j != i) (*noise)(j, i) += added;
      }
    };
    for (Eigen::Index r = 0; r < count; ++r) {
      if constexpr (M == Eigen::Dynamic) {
        add_row(r, sigma_g->col(r).head(m));
      } else {
        add_row(r, Eigen::Matrix<double, M, 1>());
      }
    }
  }

  // add_block() for a block coupled across several rows (features whose
  // fits share parameters), where each row's G_b has mostly zeros: those
  // terms are left out. With Sigma_b and G_b finite each would add a zero
  // (+0 or -0) to a sum that starts at +0 and so is never -0, which changes
  // no bit: the same results as add_block(), with a fraction of its
  // products. False, with nothing added, where G_b is not finite.
  static bool add_sparse_block(const Eigen::MatrixXd& sigma, const Eigen::MatrixXd& gathered,
                               const std::vector<Eigen::Index>& rows, Eigen::Index count, Eigen::MatrixXd* sigma_g,
                               Eigen::Ref<Eigen::MatrixXd>* noise) {
    const Eigen::Index m = sigma.rows();
    thread_local std::vector<Eigen::Index> nonzero;  // per row r, its nonzero entries, from first[r]
    thread_local std::vector<Eigen::Index> first;
    nonzero.clear();
    first.assign(static_cast<std::size_t>(count) + 1, 0);
    for (Eigen::Index r = 0; r < count; ++r) {
      for (Eigen::Index c = 0; c < m; ++c) {
        const double entry = gathered(c, r);
        if (!std::isfinite(entry)) return false;
        if (entry != 0.0) nonzero.push_back(c);
      }
      first[static_cast<std::size_t>(r) + 1] = static_cast<Eigen::Index>(nonzero.size());
    }
    const auto of_row = [&](Eigen::Index r) {
      return std::make_pair(nonzero.data() + first[static_cast<std::size_t>(r)],
                            nonzero.data() + first[static_cast<std::size_t>(r) + 1]);
    };
    for (Eigen::Index r = 0; r < count; ++r) {
      auto column = sigma_g->col(r).head(m);
      column.setZero();
      const auto [begin, end] = of_row(r);
      for (const Eigen::Index* c = begin; c != end; ++c) column += gathered(*c, r) * sigma.col(*c);
      const Eigen::Index i = rows[static_cast<std::size_t>(r)];
      for (Eigen::Index q = 0; q <= r; ++q) {
        const Eigen::Index j = rows[static_cast<std::size_t>(q)];
        double added = 0.0;
        const auto [from, to] = of_row(q);
        for (const Eigen::Index* l = from; l != to; ++l) added += column[*l] * gathered(*l, q);
        (*noise)(i, j) += added;
        if (j != i) (*noise)(j, i) += added;
      }
    }
    return true;
  }

  const std::vector<std::string>& output_names() const noexcept override { return model_->output_names(); }
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    return model_->outputs(u, y);
  }
  bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& u,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return model_->output_parameter_jacobian(u, jacobian);
  }
  const char* failure_reason() const noexcept override {
    const char* own = own_failure();
    own_failure() = nullptr;
    return own != nullptr ? own : model_->failure_reason();
  }

 private:
  static const char*& own_failure() noexcept {
    thread_local const char* reason = nullptr;
    return reason;
  }

  ModelHandle model_;
  Eigen::MatrixXd covariance_;
  // A block of Sigma: its parameters (increasing) and their covariance.
  struct Block {
    std::vector<Eigen::Index> parameters;
    Eigen::MatrixXd sigma;
    bool sigma_finite = false;
    // With declared rows (use_declared_rows()): the rows the block can move,
    // and for each of them, each parameter's entry in
    // parameter_jacobian_entries()' output (-1: it does not move that row).
    std::vector<Eigen::Index> rows;
    std::vector<int> sources;
  };
  std::vector<Block> blocks_;
  Eigen::Index largest_block_ = 0;
  Eigen::Index declared_entries_ = 0;  // > 0: the model declares its rows
  Eigen::Index largest_declared_rows_ = 0;
};

ModelHandle unwrapped(ModelHandle model) {
  if (const auto* wrapped = dynamic_cast<const ParameterUncertainModel*>(model.get())) {
    return ModelHandle(wrapped->wrapped());
  }
  return model;
}

void check_size(const sdk::MotionModel& model, const Eigen::MatrixXd& covariance) {
  const Eigen::Index p = static_cast<Eigen::Index>(model.parameter_info().size());
  if (covariance.rows() != p || covariance.cols() != p) {
    throw Error("a parameter covariance must be " + std::to_string(p) + "x" + std::to_string(p) +
                " (one row and column per parameter of the model), got " + std::to_string(covariance.rows()) + "x" +
                std::to_string(covariance.cols()));
  }
}

// `model` (unwrapped) with `covariance` (checked) added to its process noise.
ModelHandle wrapped_with(ModelHandle model, Eigen::MatrixXd covariance, double dt) {
  const Eigen::Index p = covariance.rows();
  Eigen::MatrixXd g(model->state_dim(), p);
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(model->state_dim());
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(model->input_dim());
  if (!model->parameter_jacobian(x, u, dt, g)) {
    model->failure_reason();  // clear it
    throw Error("the model gives no parameter Jacobian (parameter_jacobian()), which a parameter covariance needs");
  }
  return ModelHandle(std::make_shared<ParameterUncertainModel>(std::move(model), std::move(covariance)));
}

double step_of(const Bank& bank) { return bank.config.sampling.rate > 0.0 ? 1.0 / bank.config.sampling.rate : 0.1; }

}  // namespace

namespace internal {

const sdk::MotionModel* model_under_parameter_uncertainty(const sdk::MotionModel& model) {
  const auto* wrapper = dynamic_cast<const ParameterUncertainModel*>(&model);
  return wrapper != nullptr ? wrapper->wrapped().get() : nullptr;
}

bool add_parameter_noise(const sdk::MotionModel& model, const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::MatrixXd> noise) {
  return static_cast<const ParameterUncertainModel&>(model).add_parameter_noise(x, u, dt, noise);
}

}  // namespace internal

ModelHandle with_parameter_uncertainty(ModelHandle model, const Eigen::MatrixXd& covariance, double dt) {
  model = unwrapped(std::move(model));
  if (covariance.size() == 0) return model;
  check_size(*model, covariance);
  std::string why;
  if (!check_parameter_covariance(covariance, &why)) throw Error("a parameter covariance must be a covariance: " + why);
  // Written to 10 digits, a covariance with directions of no variance (held
  // parameters, exact combinations) can read back a hair below zero there:
  // its negative eigenvalues are taken as zero, a block at a time
  // (coupled_blocks.h), so that the zeros between blocks stay exact.
  Eigen::MatrixXd psd = Eigen::MatrixXd::Zero(covariance.rows(), covariance.cols());
  for (const std::vector<Eigen::Index>& block : coupled_blocks(covariance)) {
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(covariance(block, block));
    psd(block, block) =
        eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
  }
  return wrapped_with(std::move(model), 0.5 * (psd + psd.transpose()), dt);
}

bool check_parameter_covariance(const Eigen::MatrixXd& covariance, std::string* why) {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (covariance.rows() != covariance.cols()) {
    return fail("not square (" + std::to_string(covariance.rows()) + "x" + std::to_string(covariance.cols()) + ")");
  }
  if (covariance.size() == 0) return true;
  if (!covariance.allFinite()) return fail("has non-finite entries");
  // Symmetry as check_covariance() asks it; definiteness to the file's rounding.
  const double scale = covariance.cwiseAbs().maxCoeff();
  Eigen::MatrixXd symmetric_part = 0.5 * (covariance + covariance.transpose());
  std::string reason;
  if (!check_covariance(covariance, /*strict=*/false, &reason) && reason.rfind("not symmetric", 0) == 0) {
    return fail(reason);
  }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric_part).eigenvalues();
  if (lambda.minCoeff() < -1e-6 * std::max(lambda.maxCoeff(), 1e-300) || (scale > 0.0 && !(lambda.maxCoeff() > 0.0))) {
    std::ostringstream out;
    out << "not positive semidefinite: smallest eigenvalue " << lambda.minCoeff() << ", largest " << lambda.maxCoeff();
    return fail(out.str());
  }
  return true;
}

const Eigen::MatrixXd& parameter_covariance_of(const sdk::MotionModel& model) {
  static const Eigen::MatrixXd kNone;
  const auto* wrapped = dynamic_cast<const ParameterUncertainModel*>(&model);
  return wrapped != nullptr ? wrapped->covariance() : kNone;
}

void set_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance) {
  const std::size_t j = static_cast<std::size_t>(mode);
  bank->models[j] = with_parameter_uncertainty(bank->models[j], covariance, step_of(*bank));
  bank->config.modes[j].parameter_covariance = covariance;
}

void set_fitted_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance) {
  const std::size_t j = static_cast<std::size_t>(mode);
  ModelHandle model = unwrapped(bank->models[j]);
  if (covariance.size() > 0) {
    check_size(*model, covariance);
    // Not checked as a file's is (a fit's is a covariance by construction),
    // but a non-finite entry would turn the noise of any step into NaN.
    if (!covariance.allFinite()) {
      throw Error("mode '" + bank->config.modes[j].name + "': the fitted parameter covariance has non-finite entries");
    }
    model = wrapped_with(std::move(model), covariance, step_of(*bank));
  }
  bank->models[j] = std::move(model);
  bank->config.modes[j].parameter_covariance = covariance;
}

}  // namespace skidimm
