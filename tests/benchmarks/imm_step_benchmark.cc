// Time of one Imm::step, as a multiple of a hand-written fixed-size IMM of the
// same math timed in the same run (tests/core/reference_imm.h), and as the
// share of a core it takes at 100 Hz for 1 to 256 modes and every form of
// transition.
//
//   Imm/<bank>, Reference/<bank>: the bundled banks (ltc_terrains 3 modes x 2
//     states, stc_slip4 4 x 3, stc_slip16 16 x 3) and a 16 x 2 LTC bank, every
//     row measured, regular 50 Hz steps: the same steps for both.
//   Scaling/<form>/<states>/<modes>: LTC (2 states) and STC (3 states, with an
//     angle) banks of 1 to 256 modes with each transition form (a per-step
//     matrix, equal dwell times, per-mode dwell times) at 100 Hz with a jittered
//     dt (+-10%), as real logs have. Counters: the heap the Imm takes at
//     construction and the allocations per step (must be 0).
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>
#include <utility>

#include "benchmark_data.h"
#include "benchmark_support.h"
#include "skidimm/engine/imm.h"

namespace skidimm_bench {
namespace {

constexpr int kSteps = 1 << 14;

// Cycles through precomputed steps; at the end, resets the filter so that
// time starts over.
template <typename Filter, typename Step>
void cycle(benchmark::State& state, Filter& filter, const Steps& steps, Step&& step) {
  int k = 0;
  for (auto _ : state) {
    if (k == steps.size()) {
      filter.reset();
      k = 0;
    }
    step(k);
    ++k;
  }
  state.SetItemsProcessed(state.iterations());
}

void bank_benchmark(benchmark::State& state, const std::string& name, bool reference) {
  skidimm::Bank bank = name == "ltc16" ? ltc_bank(16, TransitionForm::kPerStep) : bundled_bank(name);
  const Steps steps = simulate_steps(bank, kSteps, 0.02, 0.0);
  const Eigen::MatrixXd transition = transition_matrix(bank.config, 0.02);
  if (!reference) {
    skidimm::Imm imm(std::move(bank));
    cycle(state, imm, steps, [&](int k) {
      const skidimm::ImmEstimate& e = imm.step(steps.t[k], steps.u[k], steps.z[k]);
      benchmark::DoNotOptimize(e.state.data());
    });
  } else if (bank.config.state_dim() == 2) {
    LtcReference filter = ltc_reference(bank);
    cycle(state, filter, steps, [&](int k) {
      filter.step(steps.t[k], steps.u[k], steps.z[k], transition);
      benchmark::DoNotOptimize(filter.state().data());
    });
  } else {
    StcReference filter = stc_reference(bank);
    cycle(state, filter, steps, [&](int k) {
      filter.step(steps.t[k], steps.u[k], steps.z[k], transition);
      benchmark::DoNotOptimize(filter.state().data());
    });
  }
}

void scaling_benchmark(benchmark::State& state, TransitionForm form, int states) {
  const int modes = static_cast<int>(state.range(0));
  skidimm::Bank bank = states == 2 ? ltc_bank(modes, form) : stc_bank(modes, form);
  const Steps steps = simulate_steps(bank, kSteps, 0.01, 0.1);
  const long bytes_before = malloc_bytes();
  skidimm::Imm imm(std::move(bank));
  const long construction_bytes = malloc_bytes() - bytes_before;
  for (int k = 0; k < 20; ++k) imm.step(steps.t[k], steps.u[k], steps.z[k]);  // warm up
  imm.reset();
  const long allocations_before = malloc_calls();
  cycle(state, imm, steps, [&](int k) {
    const skidimm::ImmEstimate& e = imm.step(steps.t[k], steps.u[k], steps.z[k]);
    benchmark::DoNotOptimize(e.state.data());
  });
  state.counters["imm_bytes"] = static_cast<double>(construction_bytes);
  state.counters["allocs_per_step"] =
      static_cast<double>(malloc_calls() - allocations_before) / static_cast<double>(state.iterations());
}

void register_step_benchmarks() {
  for (const char* bank : {"ltc_terrains", "stc_slip4", "stc_slip16", "ltc16"}) {
    for (bool reference : {false, true}) {
      const std::string name = std::string(reference ? "Reference/" : "Imm/") + bank;
      benchmark::RegisterBenchmark(name.c_str(), [bank, reference](benchmark::State& s) {
        bank_benchmark(s, bank, reference);
      });
    }
  }
  for (TransitionForm form :
       {TransitionForm::kPerStep, TransitionForm::kUniformDwell, TransitionForm::kPerModeDwell}) {
    for (int states : {2, 3}) {
      const std::string name = std::string("Scaling/") + form_name(form) + "/" + (states == 2 ? "ltc" : "stc");
      benchmark::RegisterBenchmark(name.c_str(), [form, states](benchmark::State& s) {
        scaling_benchmark(s, form, states);
      })->Arg(1)->Arg(4)->Arg(16)->Arg(64)->Arg(256);
    }
  }
}

const bool step_benchmarks_registered = (register_step_benchmarks(), true);

}  // namespace
}  // namespace skidimm_bench
