// A request from outside the program (the command line's SIGINT and SIGTERM
// handlers) that a long loop stop at its next step and keep what it has
// computed: `skidimm run` then writes its rows so far to the .partial file
// and exits 128 + the signal, where the default handling lost every row
// still in the writer's buffer.
#ifndef SKIDIMM_STOP_REQUEST_H_
#define SKIDIMM_STOP_REQUEST_H_

namespace skidimm {

// Async-signal-safe: what a signal handler calls.
void request_stop(int signal) noexcept;
// The signal of a pending request, or 0.
int stop_requested() noexcept;
void clear_stop_request() noexcept;

// "SIGINT", "SIGTERM", "SIGSEGV (segmentation fault)", ... or "a signal":
// what a message says of a signal. Async-signal-safe (a constant string).
const char* signal_name(int signal) noexcept;

}  // namespace skidimm

#endif  // SKIDIMM_STOP_REQUEST_H_
