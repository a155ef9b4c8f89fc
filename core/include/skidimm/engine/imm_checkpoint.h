// ImmCheckpoint: everything an Imm (and the decision over it) carries from
// one step to the next, so that a filter stopped after some step and
// restored in another process runs on exactly as if it had never stopped:
// a robot's node restarted mid-drive keeps what it knew of the terrain
// instead of starting again from the prior, and a log that comes in pieces
// (`skidimm run --save-checkpoint`, then `--resume`) gives the rows one run
// over the whole log gives, bit for bit.
//
// What it holds: the last step's time and input (the next prediction runs
// from them), the whole last estimate (the modes' probabilities, states and
// covariances are the filters' own), the memory of correlated innovations
// (residual_correlation) and the anchors of a chain with per-mode dwell
// times (mode_transition.h), and optionally the decision's state. Nothing
// derived from the bank is kept: a checkpoint restores into any bank of the
// same modes, states, inputs and measurement (a retuned bank, say), and into
// no other (Imm::restore checks and says what differs).
//
// Files: io/checkpoint_file.h. Made by Imm::checkpoint(), restored by
// Imm::restore() and ModeDecision::restore().
#ifndef SKIDIMM_ENGINE_IMM_CHECKPOINT_H_
#define SKIDIMM_ENGINE_IMM_CHECKPOINT_H_

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/engine/mode_transition.h"

namespace skidimm {

// One mode's last whitened innovation, remembered for the next step's
// conditional likelihood (residual_correlation: of a bank mode).
struct InnovationMemory {
  bool remembers = false;        // false: the next step starts a new memory
  int steps_since = 0;           // filter steps since the innovation
  std::vector<int> rows;         // the measurement rows it had
  std::vector<double> whitened;  // L^-1 nu over those rows
};

struct ImmCheckpoint {
  // What the bank was, checked on restore.
  std::vector<std::string> mode_names;
  std::vector<std::string> state_names;
  std::vector<std::string> input_names;
  int measurement_rows = 0;

  bool started = false;  // false: no step yet (the next is a first step)
  double t = 0.0;        // the last step's time
  Eigen::VectorXd held_input;
  ImmEstimate estimate;
  std::vector<InnovationMemory> innovations;  // per mode; empty without correlated innovations
  ModeTransition::AnchorMemory transition_anchors;
  std::optional<ModeDecision::Memory> decision;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_IMM_CHECKPOINT_H_
