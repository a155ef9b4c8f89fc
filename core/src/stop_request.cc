#include "skidimm/stop_request.h"

#include <atomic>
#include <csignal>

namespace skidimm {

namespace {

// A lock-free atomic is what a signal handler may write.
std::atomic<int> pending{0};
static_assert(std::atomic<int>::is_always_lock_free, "a signal handler may only touch a lock-free atomic");

}  // namespace

void request_stop(int signal) noexcept { pending.store(signal, std::memory_order_relaxed); }

int stop_requested() noexcept { return pending.load(std::memory_order_relaxed); }

void clear_stop_request() noexcept { pending.store(0, std::memory_order_relaxed); }

const char* signal_name(int signal) noexcept {
  switch (signal) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGSEGV:
      return "SIGSEGV (segmentation fault)";
    case SIGBUS:
      return "SIGBUS (bus error)";
    case SIGFPE:
      return "SIGFPE (arithmetic error)";
    case SIGILL:
      return "SIGILL (illegal instruction)";
    case SIGABRT:
      return "SIGABRT (abort)";
    default:
      return "a signal";
  }
}

}  // namespace skidimm
