#include "skidimm/engine/fatal_signal_report.h"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <mutex>
#include <string>
#include <vector>

#include "skidimm/stop_request.h"
#include "unwritten_rows.h"

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

// report_plugin_load_faults(): the program's name, and the library being
// loaded while `loading` is set, in fixed buffers a handler can read.
std::atomic<bool> load_faults_reported{false};
std::atomic<bool> loading{false};
char load_program[256];
char loading_path[4096];
std::mutex load_mutex;  // one load at a time: the saved handlers are one set
struct sigaction handlers_before_load[std::size(kFatal)];

void copy_truncated(const std::string& text, char* buffer, std::size_t size) {
  const std::size_t length = std::min(text.size(), size - 1);
  std::memcpy(buffer, text.data(), length);
  buffer[length] = '\0';
}

void write_all(const char* text) noexcept {
  std::size_t left = std::strlen(text);
  while (left > 0) {
    const ssize_t wrote = ::write(STDERR_FILENO, text, left);
    if (wrote <= 0) return;
    text += wrote;
    left -= static_cast<std::size_t>(wrote);
  }
}

// set_unwritten_rows(): where, and which bytes.
std::atomic<int> unwritten_fd{-1};
std::atomic<const char*> unwritten_data{nullptr};
std::atomic<std::size_t> unwritten_size{0};

void write_unwritten_rows() noexcept {
  const int fd = unwritten_fd.load(std::memory_order_relaxed);
  const char* data = unwritten_data.load(std::memory_order_relaxed);
  std::size_t left = unwritten_size.load(std::memory_order_relaxed);
  if (fd < 0 || data == nullptr) return;
  while (left > 0) {
    const ssize_t wrote = ::write(fd, data, left);
    if (wrote <= 0) return;
    data += wrote;
    left -= static_cast<std::size_t>(wrote);
  }
}

void on_fatal_signal(int signal) noexcept {
  if (loading.load(std::memory_order_relaxed)) {
    write_all("\n");
    write_all(load_program);
    write_all(": ");
    write_all(signal_name(signal));
    write_all(" while loading the plugin library ");
    write_all(loading_path);
    write_all(": the fault is in its load-time code (a static constructor); fix or remove that file\n");
    ::raise(signal);
    return;
  }
  if (messages == nullptr) {  // only the handlers of a load were installed, and it has ended
    ::raise(signal);
    return;
  }
  const int mode = internal::mode_in_model_call.load(std::memory_order_relaxed);
  const std::vector<std::string>& m = *messages;
  const std::size_t modes = m.size() - 2;
  const std::size_t line = mode >= 0 && static_cast<std::size_t>(mode) < modes ? 1 + static_cast<std::size_t>(mode)
                                                                              : m.size() - 1;
  // The message first: writing the rows may wait on a reader of a pipe.
  write_all("\n");
  write_all(m.front().c_str());
  write_all(signal_name(signal));
  write_all(m[line].c_str());
  write_unwritten_rows();
  // SA_RESETHAND put the default action back: raising the signal again ends
  // the program as it would have ended (and its exit status says so).
  ::raise(signal);
}

// Installs on_fatal_signal() for each of kFatal (SA_RESETHAND: the signal's
// default action is back when it runs); the handlers it replaces go into
// `before`, when given.
void install_fatal_signal_handlers(struct sigaction* before) {
  struct sigaction action {};
  action.sa_handler = on_fatal_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESETHAND | SA_NODEFER;
  for (std::size_t k = 0; k < std::size(kFatal); ++k) {
    ::sigaction(kFatal[k], &action, before != nullptr ? &before[k] : nullptr);
  }
}

// An exit() from a library's load-time code runs the handlers std::atexit()
// registered before it, this one among them: it names the library and ends
// the program with status 1 at once.
void on_exit_while_loading() noexcept {
  if (!loading.load(std::memory_order_relaxed)) return;
  write_all(load_program);
  write_all(": the plugin library ");
  write_all(loading_path);
  write_all(
      " called exit() while it was being loaded (in its load-time code, a static constructor); fix or remove "
      "that file\n");
  ::_exit(1);
}

}  // namespace

void report_fatal_signals(const std::string& program, std::vector<std::string> mode_descriptions) {
  report_fatal_signals(program, std::move(mode_descriptions), FatalSignalWording{});
}

void report_fatal_signals(const std::string& program, std::vector<std::string> mode_descriptions,
                          const FatalSignalWording& wording) {
  // messages[0]: "<program>: "; messages[1 + j]: mode j's line; last: no model running.
  auto* lines = new std::vector<std::string>();  // lives until the program ends: a handler may read it
  lines->push_back(program + ": ");
  for (const std::string& mode : mode_descriptions) {
    lines->push_back(" while the model of " + mode + " was running: the fault is that plugin's; " + wording.lost +
                     "\n");
  }
  const bool marked = wording.every_model_call_marked && !wording.several_threads;
  lines->push_back(marked ? " while no model was running: a fault of skidimm itself, please report it\n"
                          : ": the fault is in one of the bank's plugins (" + wording.plugins +
                                ") or in skidimm itself; `skidimm run` on a log with this bank names the mode "
                                "when it is a plugin's; " +
                                wording.lost + "\n");
  messages = lines;
  install_fatal_signal_handlers(nullptr);
  if (!wording.several_threads) internal::fatal_signals_reported.store(true, std::memory_order_relaxed);
}

void report_plugin_load_faults(const std::string& program) {
  copy_truncated(program, load_program, sizeof(load_program));
  if (!load_faults_reported.exchange(true)) std::atexit(on_exit_while_loading);
}

namespace internal {

PluginLoadMark::PluginLoadMark(const std::string& path) {
  if (!load_faults_reported.load(std::memory_order_relaxed)) return;
  load_mutex.lock();
  on_ = true;
  copy_truncated(path, loading_path, sizeof(loading_path));
  install_fatal_signal_handlers(handlers_before_load);
  loading.store(true, std::memory_order_relaxed);
}

PluginLoadMark::~PluginLoadMark() {
  if (!on_) return;
  loading.store(false, std::memory_order_relaxed);
  for (std::size_t k = 0; k < std::size(kFatal); ++k) ::sigaction(kFatal[k], &handlers_before_load[k], nullptr);
  load_mutex.unlock();
}

void set_unwritten_rows(int fd, const char* data, std::size_t size) noexcept {
  unwritten_fd.store(-1, std::memory_order_relaxed);  // no bytes of one buffer with the size of another
  unwritten_data.store(data, std::memory_order_relaxed);
  unwritten_size.store(size, std::memory_order_relaxed);
  unwritten_fd.store(fd, std::memory_order_relaxed);
}

void clear_unwritten_rows() noexcept { unwritten_fd.store(-1, std::memory_order_relaxed); }

std::atomic<bool> fatal_signals_reported{false};
std::atomic<int> mode_in_model_call{-1};

}  // namespace internal
}  // namespace skidimm
