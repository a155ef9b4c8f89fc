// What fitting by likelihood costs (likelihood_fitter.h), over 10^4 rows
// simulated from the model itself (tests/fitting/simulated_logs.h):
//
//   Likelihood/<model>/nll:       one NLL (evaluate_likelihood), the reference;
//   Likelihood/<model>/gradient:  one NLL with its gradient and BHHH
//                                 information (evaluate_likelihood_derivatives);
//   Likelihood/<model>/fit:       a whole fit (fit_likelihood) from every
//                                 parameter 20 % off, Q at the bank's.
//
// for ltc_linear (2 states, 8 parameters and a parameter Jacobian) and
// linear_features with 6 states and 42 parameters (A diagonal with B 6 x 5
// and c, or A full with B 6 x 1). The table at the end (benchmark_main.cc)
// gives the gradient and the fit in NLLs of the same run. That both
// evaluations agree on the NLL is a test (likelihood_fitter_test.cc).
#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "core/test_banks.h"
#include "fitting/simulated_logs.h"
#include "skidimm/fitting/likelihood_fitter.h"

namespace skidimm_bench {
namespace {

using skidimm::Bank;
using skidimm::fitting::ModeLogs;
using skidimm::fitting::Trajectory;

// ltc_linear at the truth of likelihood_fitter_test.cc's LTC recoveries, and
// its log.
struct Case {
  Bank bank;
  Trajectory log;
};

Case ltc_case() {
  Eigen::Matrix2d a, b;
  a << -4.0, 0.3, 0.2, -3.0;
  b << 0.35, 0.3, -0.7, 0.75;
  const Eigen::Matrix2d q = Eigen::Vector2d(2e-3, 3e-3).asDiagonal();
  const Eigen::Matrix2d r = Eigen::Vector2d(1e-4, 1e-4).asDiagonal();
  Case c;
  skidimm_test::BankBuilder builder;
  builder.models = {skidimm_test::make_ltc(a, b)};
  builder.states = builder.models[0]->state_names();
  builder.angles = {false, false};
  builder.inputs = builder.models[0]->input_names();
  builder.q = {Eigen::Matrix2d(Eigen::Vector2d(0.01, 0.01).asDiagonal())};
  builder.h = Eigen::Matrix2d::Identity();
  builder.r = r;
  c.bank = builder.build();
  c.log = skidimm_test::simulate(*builder.models[0], q, Eigen::Matrix2d::Identity(), r, 10000, 0.02,
                                 skidimm_test::rich_wheel_speeds, 101);
  return c;
}

std::filesystem::path bank_directory() {
  const std::filesystem::path directory = std::filesystem::temp_directory_path() / "skidimm_likelihood_benchmark";
  std::filesystem::create_directories(directory);
  return directory;
}

Case six_state_case(bool full_a) {
  Case c;
  c.bank = full_a ? skidimm_test::six_states_full_a(bank_directory())
                  : skidimm_test::six_states_diagonal_a(bank_directory());
  c.log = skidimm_test::six_state_log(*c.bank.models[0], full_a ? 103 : 102);
  return c;
}

void nll(benchmark::State& state, const std::function<Case()>& make) {
  const Case c = make();
  const ModeLogs data{0, {c.log}};
  for (auto _ : state) {
    const skidimm::fitting::LikelihoodEvaluation value = skidimm::fitting::evaluate_likelihood(c.bank, data);
    if (!value.failure.empty()) state.SkipWithError(value.failure.c_str());
    benchmark::DoNotOptimize(value.negative_log_likelihood);
  }
}

void gradient(benchmark::State& state, const std::function<Case()>& make) {
  Case c = make();
  const ModeLogs data{0, {c.log}};
  for (auto _ : state) {
    const skidimm::fitting::LikelihoodEvaluation value =
        skidimm::fitting::evaluate_likelihood_derivatives(&c.bank, data);
    if (!value.failure.empty()) state.SkipWithError(value.failure.c_str());
    benchmark::DoNotOptimize(value.gradient.data());
  }
}

void fit(benchmark::State& state, const std::function<Case()>& make) {
  Case c = make();
  const ModeLogs data{0, {c.log}};
  const std::shared_ptr<skidimm::sdk::MotionModel>& model = c.bank.models[0];
  Eigen::VectorXd truth(static_cast<Eigen::Index>(model->parameter_info().size()));
  model->get_parameters(truth);
  const Eigen::MatrixXd bank_q = c.bank.config.modes[0].q_intensity;
  int iterations = 0;
  for (auto _ : state) {
    state.PauseTiming();
    if (!model->set_parameters(truth * 0.8, nullptr)) state.SkipWithError("the start is out of range");
    c.bank.config.modes[0].q_intensity = bank_q;
    state.ResumeTiming();
    iterations = skidimm::fitting::fit_likelihood(&c.bank, {data}).front().iterations;
  }
  state.counters["lbfgs_iterations"] = iterations;
}

const std::function<Case()> kLtc = ltc_case;
const std::function<Case()> kDiagonalA = [] { return six_state_case(false); };
const std::function<Case()> kFullA = [] { return six_state_case(true); };

BENCHMARK_CAPTURE(nll, ltc_linear, kLtc)->Name("Likelihood/ltc_linear/nll")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(gradient, ltc_linear, kLtc)->Name("Likelihood/ltc_linear/gradient")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(fit, ltc_linear, kLtc)
    ->Name("Likelihood/ltc_linear/fit")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(nll, six_diagonal_a, kDiagonalA)
    ->Name("Likelihood/six_diagonal_a/nll")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(gradient, six_diagonal_a, kDiagonalA)
    ->Name("Likelihood/six_diagonal_a/gradient")
    ->Unit(benchmark::kMillisecond);
// A whole 6-state fit takes seconds: one run of it.
BENCHMARK_CAPTURE(fit, six_diagonal_a, kDiagonalA)
    ->Name("Likelihood/six_diagonal_a/fit")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(1);
BENCHMARK_CAPTURE(nll, six_full_a, kFullA)->Name("Likelihood/six_full_a/nll")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(gradient, six_full_a, kFullA)->Name("Likelihood/six_full_a/gradient")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(fit, six_full_a, kFullA)
    ->Name("Likelihood/six_full_a/fit")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->Repetitions(1);

}  // namespace
}  // namespace skidimm_bench
