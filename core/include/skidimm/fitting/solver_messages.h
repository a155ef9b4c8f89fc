// Ceres' own messages, through skidimm's reporting instead of straight to
// stderr.
//
// Ceres logs with glog, which (uninitialised) prints every warning and error
// on stderr: a fit on a bad log could bury the one line that says what is
// wrong under kilobytes of "Error in evaluating the ResidualBlock". After
// capture_solver_messages(), glog writes nothing itself (no stderr below
// FATAL, no log files); its warnings and errors are kept, at most a few
// hundred, and take_solver_messages() hands them to the command, which
// summarises them. INFO messages are dropped. A FATAL message still reaches
// stderr: the process is about to abort.
//
// Process-wide (glog is); thread-safe. Call it once before solving.
#ifndef SKIDIMM_FITTING_SOLVER_MESSAGES_H_
#define SKIDIMM_FITTING_SOLVER_MESSAGES_H_

#include <string>

namespace skidimm {
namespace fitting {

void capture_solver_messages();

// The messages captured since the last call, summarised: the count and the
// first few distinct ones, one per line, each indented by `indent`; empty
// when there were none.
std::string take_solver_messages(const std::string& indent = "  ");

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_SOLVER_MESSAGES_H_
