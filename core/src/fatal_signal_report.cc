#include "skidimm/engine/fatal_signal_report.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <string>
#include <vector>

#include "skidimm/stop_request.h"

namespace skidimm {

namespace {

static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free,
              "a signal handler may only read lock-free atomics");

// Written once, before the handlers are installed, and only read after:
// what the handler prints, whole lines, with no allocation in it.
std::vector<std::string>* messages = nullptr;  // per mode, then the one for "no model running"

// Under AddressSanitizer its own reports of the memory faults say more (the
// access, the stack): they stay its own.
#if defined(__SANITIZE_ADDRESS__)
#define SKIDIMM_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SKIDIMM_ASAN 1
#endif
#endif
#ifdef SKIDIMM_ASAN
constexpr int kFatal[] = {SIGABRT};
#else
constexpr int kFatal[] = {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT};
#endif

void write_all(const char* text) noexcept {
  std::size_t left = std::strlen(text);
  while (left > 0) {
    const ssize_t wrote = ::write(STDERR_FILENO, text, left);
    if (wrote <= 0) return;
    text += wrote;
    left -= static_cast<std::size_t>(wrote);
  }
}

void on_fatal_signal(int signal) noexcept {
  const int mode = internal::mode_in_model_call.load(std::memory_order_relaxed);
  const std::vector<std::string>& m = *messages;
  const std::size_t modes = m.size() - 2;
  const std::size_t line = mode >= 0 && static_cast<std::size_t>(mode) < modes ? 1 + static_cast<std::size_t>(mode)
                                                                              : m.size() - 1;
  write_all("\n");
  write_all(m.front().c_str());
  write_all(signal_name(signal));
  write_all(m[line].c_str());
  // SA_RESETHAND put the default action back: raising the signal again ends
  // the program as it would have ended (and its exit status says so).
  ::raise(signal);
}

}  // namespace

void report_fatal_signals(const std::string& program, std::vector<std::string> mode_descriptions) {
  // messages[0]: "<program>: "; messages[1 + j]: mode j's line; last: no model running.
  auto* lines = new std::vector<std::string>();  // lives until the program ends: a handler may read it
  lines->push_back(program + ": ");
  for (const std::string& mode : mode_descriptions) {
    lines->push_back(" while the model of " + mode +
                     " was running: the fault is that plugin's; rows not yet written are lost (--flush writes "
                     "each row as it is computed)\n");
  }
  lines->push_back(" while no model was running: a fault of skidimm itself, please report it\n");
  messages = lines;
  struct sigaction action {};
  action.sa_handler = on_fatal_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND | SA_NODEFER;
  for (const int signal : kFatal) ::sigaction(signal, &action, nullptr);
  internal::fatal_signals_reported.store(true, std::memory_order_relaxed);
}

namespace internal {

std::atomic<bool> fatal_signals_reported{false};
std::atomic<int> mode_in_model_call{-1};

}  // namespace internal
}  // namespace skidimm
