// Cost of one IMM step as the bank grows, as a ratio to a one-mode bank (a
// plain EKF) measured in the same run: the ratio is what to compare across
// machines. Run: build/bin/skidimm_benchmarks
#include <benchmark/benchmark.h>

#include <cmath>

#include "core/test_banks.h"
#include "skidimm/imm.h"

namespace {

skidimm::Imm make_ltc_imm(int num_modes) {
  skidimm_test::BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d input;
  input << 0.4, 0.4, -0.8, 0.8;
  for (int j = 0; j < num_modes; ++j) {
    b.models.push_back(skidimm_test::make_ltc(Eigen::Matrix2d::Identity() * -(1.0 + 0.1 * j), (0.3 + 0.01 * j) * input));
  }
  b.q = {Eigen::Matrix2d::Identity() * 0.01};
  b.r = Eigen::Matrix2d::Identity() * 0.01;
  return skidimm::Imm(b.build());
}

void BM_ImmStep(benchmark::State& state) {
  skidimm::Imm imm = make_ltc_imm(static_cast<int>(state.range(0)));
  double t = 0.0;
  for (auto _ : state) {
    t += 0.02;
    const auto& e = imm.step(t, Eigen::Vector2d(3.0, 4.0), Eigen::Vector2d(0.5 + 0.1 * std::sin(t), 0.1));
    benchmark::DoNotOptimize(e.state.data());
  }
  state.counters["modes"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_ImmStep)->Arg(1)->Arg(4)->Arg(16)->Arg(64)->Arg(256);

}  // namespace

BENCHMARK_MAIN();
