// PluginRegistry: finds motion-model plugins on a search path and creates
// models from them.
//
// Search order (first match wins; later directories are shadowed):
//   1. paths given explicitly (the CLI's --plugin-path),
//   2. the bank file's `plugin_paths` (relative to the bank file),
//   3. the directories in $SKIDIMM_PLUGIN_PATH (':'-separated),
//   4. the installed plugin directory (<prefix>/lib/skidimm/plugins, found
//      next to the running executable and at the configured install prefix).
// A search-path entry may be a directory (every shared library in it is
// examined) or a single plugin file. Only regular files are opened: a FIFO,
// a device or a socket (given, or named like a library in a directory) is a
// rejected plugin saying what it is, never opened (a FIFO would block the
// open forever); so is a file over 1 GiB, and one whose reading or loading
// runs out of memory.
//
// Lifetime: a model created here owns a reference to its library, so the
// library stays loaded while the model lives, even after the registry is gone
// (Boost.DLL tutorial 8). A plugin is unloaded when the registry and the
// last model created from it are destroyed, on whichever thread destroys the
// last of them; never while a model from it lives.
//
// Thread safety: a PluginRegistry is used by one thread at a time (plugins(),
// find() and create() scan and cache). Separate registries on separate
// threads are independent, even over the same plugin files. Models created
// here may be used and destroyed on any thread. Pinned by
// tests/core/thread_safety_test.cc under ThreadSanitizer (docs/engine.md).
#ifndef SKIDIMM_ENGINE_PLUGIN_REGISTRY_H_
#define SKIDIMM_ENGINE_PLUGIN_REGISTRY_H_

#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameters.h"

namespace boost {
namespace dll {
class shared_library;
}
}  // namespace boost

namespace skidimm {

// A model instance whose deleter keeps its plugin library loaded: a
// shared_ptr that cannot be dereferenced while it is a temporary. In
//   for (const auto& info : registry.create(...)->parameter_info())
// the model would be destroyed before the loop reads the vector it returned
// a reference to (a use after free); that line does not compile. Name the
// handle first: `ModelHandle model = registry.create(...);`.
class ModelHandle : public std::shared_ptr<sdk::MotionModel> {
 public:
  using std::shared_ptr<sdk::MotionModel>::shared_ptr;
  ModelHandle() = default;
  ModelHandle(std::shared_ptr<sdk::MotionModel> model) noexcept  // NOLINT: a handle is a shared_ptr
      : std::shared_ptr<sdk::MotionModel>(std::move(model)) {}

  sdk::MotionModel* operator->() const& noexcept { return get(); }
  sdk::MotionModel* operator->() const&& = delete;
  sdk::MotionModel& operator*() const& noexcept { return *get(); }
  sdk::MotionModel& operator*() const&& = delete;
};

// A state or input a plugin declares (sdk::VariableDoc).
struct PluginVariable {
  std::string name;
  std::string description;
  bool is_angle = false;
};

// What `skidimm plugins` shows about one library found on the search path.
struct PluginDescriptor {
  std::filesystem::path path;
  std::string name;  // empty if the library could not be read
  std::string version;
  std::string description;
  std::vector<std::string> parameter_docs;  // "key (shape): description"
  std::vector<std::string> parameter_keys;
  // The keys the plugin documents as bank-level: their ParameterDoc
  // description ends with "bank-level (shared:)", as function models write it
  // (function_model.h) and class-form plugins are asked to.
  std::vector<std::string> shared_parameter_keys;
  // Empty when the plugin's models take the bank's own states (inputs).
  std::vector<PluginVariable> states;
  std::vector<PluginVariable> inputs;
  std::vector<PluginVariable> outputs;  // what its models predict besides the state (MotionModel::outputs())
  std::string error;      // non-empty: the library is unusable, and why
  bool shadowed = false;  // a plugin of the same name comes earlier on the path
  // Another file in the same search-path entry claims the same name (neither
  // can be used: find() refuses to choose); the other file's path.
  std::filesystem::path duplicate_of;
};

class PluginRegistry {
 public:
  explicit PluginRegistry(std::vector<std::filesystem::path> search_path);
  ~PluginRegistry();
  PluginRegistry(const PluginRegistry&) = delete;
  PluginRegistry& operator=(const PluginRegistry&) = delete;

  // The standard search path: explicit, then bank, then $SKIDIMM_PLUGIN_PATH,
  // then the installed plugin directories. Duplicates are dropped.
  static std::vector<std::filesystem::path> standard_search_path(
      const std::vector<std::filesystem::path>& explicit_paths,
      const std::vector<std::filesystem::path>& bank_paths = {});

  const std::vector<std::filesystem::path>& search_path() const { return search_path_; }

  // Every library found, in search order, including unusable ones.
  const std::vector<PluginDescriptor>& plugins();

  // The usable plugin `name`; throws PluginError if none (listing what was
  // found), or if two different files in one directory both claim the name.
  const PluginDescriptor& find(const std::string& name);

  // Creates a model. Throws PluginError naming the plugin path when the
  // plugin rejects the parameters or fails.
  ModelHandle create(const std::string& name, const sdk::ParameterSet& params);

 private:
  void scan();

  std::vector<std::filesystem::path> search_path_;
  bool scanned_ = false;
  std::vector<PluginDescriptor> descriptors_;
  std::vector<std::shared_ptr<boost::dll::shared_library>> libraries_;  // parallel to descriptors_
  std::vector<std::size_t> search_entry_of_;  // which search_path_ entry each descriptor came from
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_PLUGIN_REGISTRY_H_
