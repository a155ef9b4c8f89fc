// What a fatal signal names. A plugin is code in skidimm's own process: a
// segmentation fault or an abort in it ends the program, which no exception
// handler can prevent. What the command line can still do is say where it
// happened: which mode's model was running, or which plugin library was
// being loaded (not "Segmentation fault" alone), so that the user knows which
// plugin to suspect.
#ifndef SKIDIMM_ENGINE_FATAL_SIGNAL_REPORT_H_
#define SKIDIMM_ENGINE_FATAL_SIGNAL_REPORT_H_

#include <atomic>
#include <string>
#include <vector>

namespace skidimm {

// From now on, SIGSEGV, SIGBUS, SIGFPE, SIGILL and SIGABRT (SIGABRT alone
// under AddressSanitizer, whose own reports say more) print "<program>:
// <signal> while the model of <mode_descriptions[j]> was running" when they
// arrive while the engine runs mode j's model (or that no model was running),
// then end the program as the signal would have. For a program that steps one
// Imm at a time (skidimm run): the engine marks the mode it calls on any
// thread, so two at once would be named ambiguously.
void report_fatal_signals(const std::string& program, std::vector<std::string> mode_descriptions);

// How report_fatal_signals() words a fault, for commands other than `run`.
struct FatalSignalWording {
  // What the fault cost, after "... was running: the fault is that plugin's; ".
  std::string lost = "rows not yet written are lost (--flush writes each row as it is computed)";
  // True where every call the program makes into a plugin is marked (it runs
  // models only through Imm): a fault outside them is then skidimm's own.
  // Otherwise (a fit, a simulation) an unmarked fault may be a plugin's, and
  // the report says so, naming `plugins`.
  bool every_model_call_marked = true;
  std::string plugins;
  // Models run on several threads at once: no mode is named (the mode
  // marked last need not be the one whose model faulted, and marking from
  // every thread would make them share one cache line at every model call),
  // so every fault is worded as unmarked.
  bool several_threads = false;
};
void report_fatal_signals(const std::string& program, std::vector<std::string> mode_descriptions,
                          const FatalSignalWording& wording);

// Loading a plugin library runs its load-time code (static constructors) in
// skidimm's process. From now on, while a library is loaded, the signals
// above print "<program>: <signal> while loading the plugin library <path>:
// ..." before the program ends as the signal would have ended it, and a call
// to exit() from that code prints that the library called exit() and ends the
// program with status 1, whatever status the library chose (0 would read as
// success). For a program (the command line), once, before it loads plugins;
// the plugin registry marks each load (PluginLoadMark). _exit() from a
// library cannot be seen.
void report_plugin_load_faults(const std::string& program);

namespace internal {

// Whether report_fatal_signals() is on, and the mode whose model runs (-1:
// none); the engine's kernel sets it around each mode's model calls.
extern std::atomic<bool> fatal_signals_reported;
extern std::atomic<int> mode_in_model_call;

// Marks mode j's model calls for the report, when it is on (one load of a
// flag otherwise, no store: the tuner's threads share nothing here).
class ModelCallMark {
 public:
  explicit ModelCallMark(int mode) noexcept : on_(fatal_signals_reported.load(std::memory_order_relaxed)) {
    if (on_) mode_in_model_call.store(mode, std::memory_order_relaxed);
  }
  ~ModelCallMark() {
    if (on_) mode_in_model_call.store(-1, std::memory_order_relaxed);
  }
  ModelCallMark(const ModelCallMark&) = delete;
  ModelCallMark& operator=(const ModelCallMark&) = delete;

 private:
  const bool on_;
};

// Marks the loading of the library at `path` for report_plugin_load_faults(),
// when it is on: its handlers are installed for the load, and the ones before
// are put back after it. Loads are serialized (dlopen's own loads are not
// thread safe in the plugin registry's use either).
class PluginLoadMark {
 public:
  explicit PluginLoadMark(const std::string& path);
  ~PluginLoadMark();
  PluginLoadMark(const PluginLoadMark&) = delete;
  PluginLoadMark& operator=(const PluginLoadMark&) = delete;

 private:
  bool on_ = false;
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_FATAL_SIGNAL_REPORT_H_
