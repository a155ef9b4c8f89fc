// The process noise that makes a mode's own filter consistent on its logs
// (model_fitter.h, evaluate()): for each state s, the diagonal intensity Q_ss
// at which the mean normalized innovation squared (NIS) of s's measurement
// over the mode's logs is 1. Private to the fitting library.
//
// NIS falls as Q_ss grows, so each entry is the root of log NIS(log Q_ss) on
// [1e-10, 1e3], found by TOMS 748 (Alefeld, Potra & Shi 1995: bracketing like
// bisection, converging like inverse cubic interpolation; about 8 filter
// passes where bisection took 30), in two rounds over the states, each solved
// with the others' latest values: 2 n searches of about 10 evaluations, each
// a pass of the mode's filter over every log.
//
// Most banks of many states are decoupled: F and the discrete process noise
// diagonal at every step, R diagonal and one measurement row per state
// (linear_features with a diagonal A, BorealTC's nine features). Each
// state's filter is then a scalar filter of its own, and its NIS depends on
// its own Q_ss alone, to the bit. So one pass of the filter evaluates every
// state's search at once, and the second round would only repeat the first:
// about 10 passes instead of 20 n. The searches are TOMS 748 itself, replayed
// (process_noise_search.cc); every pass checks the structure, and the
// independence is checked once more at the end by moving the other states'
// Q between the values the two rounds give them. Anything else (a coupled
// step, a filter that fails) runs the two rounds as above, so the result is
// theirs either way.
#ifndef SKIDIMM_CORE_SRC_FITTING_PROCESS_NOISE_SEARCH_H_
#define SKIDIMM_CORE_SRC_FITTING_PROCESS_NOISE_SEARCH_H_

#include <Eigen/Core>
#include <vector>

#include "measurement_layout.h"
#include "skidimm/config/bank.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {
namespace internal {

struct ConsistentProcessNoise {
  Eigen::VectorXd intensity;  // Q_ss, per state
  // R alone explains the state's innovations: its Q_ss is at the floor 1e-10.
  std::vector<bool> at_floor;
  // Its filter is overconfident even at the search's ceiling, Q_ss = 1e3: a
  // state in large units (mA for A), or a model that misses by far more.
  std::vector<bool> at_ceiling;
};

// Mode data.mode's consistent diagonal Q at the model's current parameters;
// m is its layout (measurement_layout.h, layout_of()).
ConsistentProcessNoise consistent_process_noise(const Bank& bank, const ModeLogs& data, const MeasurementLayout& m);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_PROCESS_NOISE_SEARCH_H_
