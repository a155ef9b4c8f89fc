#include "skidimm/engine/plugin_registry.h"

#include <algorithm>
#include <boost/dll/runtime_symbol_info.hpp>
#include <boost/dll/shared_library.hpp>
#include <cstdlib>
#include <exception>
#include <new>
#include <set>
#include <sstream>
#include <stdexcept>

#include "skidimm/engine/fatal_signal_report.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/abi.h"
#include "skidimm/sdk/export.h"
#include "skidimm/sdk/plugin_info.h"
#include "skidimm/sdk/private_library.h"

#ifndef SKIDIMM_INSTALLED_PLUGIN_DIR
#define SKIDIMM_INSTALLED_PLUGIN_DIR ""
#endif
#ifndef SKIDIMM_PLUGIN_SUBDIR
#define SKIDIMM_PLUGIN_SUBDIR "lib/skidimm/plugins"
#endif

namespace skidimm {
namespace fs = std::filesystem;

namespace {

bool documents_bank_level(const sdk::ParameterDoc& doc) {
  if (doc.description == nullptr) return false;
  const std::string description = doc.description;
  const std::string suffix = sdk::kBankLevelDoc;
  return description.size() >= suffix.size() &&
         description.compare(description.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::vector<fs::path> split_path_list(const char* list) {
  std::vector<fs::path> out;
  if (list == nullptr) return out;
  std::stringstream stream(list);
  std::string item;
  while (std::getline(stream, item, ':')) {
    if (!item.empty()) out.emplace_back(item);
  }
  return out;
}

bool is_shared_library(const fs::path& path) { return path.extension() == boost::dll::shared_library::suffix(); }

// No plugin is this large; a larger file on the search path is not read
// into memory to find out.
constexpr std::uintmax_t kMaxPluginBytes = std::uintmax_t{1} << 30;

// Why `path` cannot be a plugin file before anything opens it, or "": only
// regular files are read (opening a FIFO waits for a writer forever; a
// device is no library).
std::string not_a_plugin_file(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec) return "cannot read: " + ec.message();
  if (fs::is_regular_file(status)) {
    const std::uintmax_t size = fs::file_size(path, ec);
    if (ec) return "cannot read: " + ec.message();
    if (size > kMaxPluginBytes) {
      return "the file is " + std::to_string(size) + " bytes long, larger than a plugin can be (" +
             std::to_string(kMaxPluginBytes) + " bytes)";
    }
    return "";
  }
  const char* kind = fs::is_fifo(status)             ? "a FIFO"
                     : fs::is_character_file(status) ? "a character device"
                     : fs::is_block_file(status)     ? "a block device"
                     : fs::is_socket(status)         ? "a socket"
                     : fs::is_directory(status)      ? "a directory"
                                                     : "not a regular file";
  return std::string("not a plugin file: ") + kind + " (a plugin is a shared library, a regular file)";
}

// Reads one library. Fills `descriptor`; returns the loaded library when it is
// a usable plugin, nullptr otherwise (descriptor.error says why).
std::shared_ptr<boost::dll::shared_library> inspect_or_throw(const fs::path& path, PluginDescriptor* descriptor) {
  descriptor->path = path;
  descriptor->error = not_a_plugin_file(path);
  if (!descriptor->error.empty()) return nullptr;
  // From a private copy: rewriting or truncating the file later cannot
  // reach the loaded code, and a truncated file is refused, not mapped.
  std::string load_error;
  std::shared_ptr<boost::dll::shared_library> library;
  {
    const internal::PluginLoadMark loading(path.string());  // names the library if its load-time code crashes
    library = sdk::load_private_copy(path, &load_error);
  }
  if (library == nullptr) {
    descriptor->error = "cannot load: " + load_error;
    return nullptr;
  }
  if (!library->has(sdk::kAbiVersionSymbol)) {
    descriptor->error = std::string("not a skidimm plugin: no '") + sdk::kAbiVersionSymbol +
                        "' symbol (was it built with SKIDIMM_EXPORT_MOTION_MODEL?)";
    return nullptr;
  }
  if (library->has(sdk::kPluginNameSymbol)) {
    // A C string from another library: null is its bug, not a crash of ours.
    const char* name = library->get_alias<const char*()>(sdk::kPluginNameSymbol)();
    if (name == nullptr) {
      descriptor->error = std::string("incomplete plugin: '") + sdk::kPluginNameSymbol + "' returned no name (null)";
      return nullptr;
    }
    descriptor->name = name;
  }
  const int abi = library->get_alias<int()>(sdk::kAbiVersionSymbol)();
  if (abi != sdk::kAbiVersion) {
    descriptor->error = "built for skidimm plugin ABI " + std::to_string(abi) + ", but this skidimm uses ABI " +
                        std::to_string(sdk::kAbiVersion) + ": rebuild the plugin against this SDK";
    return nullptr;
  }
  // Same version, other standard library: std::string and std::vector in the
  // factory's arguments would be read with another layout (abi.h).
  if (!library->has(sdk::kStdlibAbiTagSymbol)) {
    descriptor->error = std::string("incomplete plugin: missing symbol '") + sdk::kStdlibAbiTagSymbol + "'";
    return nullptr;
  }
  const char* tag = library->get_alias<const char*()>(sdk::kStdlibAbiTagSymbol)();
  if (tag == nullptr || std::string(tag) != sdk::kStdlibAbiTag) {
    descriptor->error = std::string("built with another C++ standard library configuration (") +
                        (tag == nullptr ? "none given" : tag) + ") than this skidimm (" + sdk::kStdlibAbiTag +
                        "): std::string and std::vector would cross between them with different layouts. Rebuild "
                        "the plugin with the same standard library settings (no -D_GLIBCXX_USE_CXX11_ABI=0, "
                        "-D_GLIBCXX_DEBUG or -stdlib=libc++ unless skidimm was built with it)";
    return nullptr;
  }
  for (const char* symbol : {sdk::kPluginNameSymbol, sdk::kPluginInfoSymbol, sdk::kFactorySymbol}) {
    if (!library->has(symbol)) {
      descriptor->error = std::string("incomplete plugin: missing symbol '") + symbol + "'";
      return nullptr;
    }
  }
  const sdk::PluginInfo* info = library->get_alias<const sdk::PluginInfo*()>(sdk::kPluginInfoSymbol)();
  if (info == nullptr || info->name == nullptr || info->name[0] == '\0') {
    descriptor->error = "the plugin's info has no name";
    return nullptr;
  }
  descriptor->name = info->name;
  descriptor->version = info->version != nullptr ? info->version : "";
  descriptor->description = info->description != nullptr ? info->description : "";
  if (info->num_parameters > 0 && info->parameters == nullptr) {
    descriptor->error =
        "the plugin's info lists " + std::to_string(info->num_parameters) + " parameters but gives none (null)";
    return nullptr;
  }
  const auto text = [](const char* c_string) { return std::string(c_string != nullptr ? c_string : ""); };
  for (int i = 0; i < info->num_parameters; ++i) {
    const sdk::ParameterDoc& doc = info->parameters[i];
    if (doc.key == nullptr || doc.key[0] == '\0') {
      descriptor->error = "the plugin's info has a parameter without a key (parameter " + std::to_string(i) + ")";
      return nullptr;
    }
    descriptor->parameter_keys.emplace_back(doc.key);
    if (documents_bank_level(doc)) descriptor->shared_parameter_keys.emplace_back(doc.key);
    descriptor->parameter_docs.push_back(text(doc.key) + " (" + text(doc.shape) + "): " + text(doc.description));
  }
  auto variables = [](const sdk::VariableDoc* docs, int count, std::vector<PluginVariable>* out) {
    for (int i = 0; docs != nullptr && i < count; ++i) {
      out->push_back({docs[i].name != nullptr ? docs[i].name : "?",
                      docs[i].description != nullptr ? docs[i].description : "", docs[i].is_angle});
    }
  };
  variables(info->states, info->num_states, &descriptor->states);
  variables(info->inputs, info->num_inputs, &descriptor->inputs);
  variables(info->outputs, info->num_outputs, &descriptor->outputs);
  return library;
}

// The same, with running out of memory while reading or loading the file a
// rejected plugin with its reason, not the end of the program.
std::shared_ptr<boost::dll::shared_library> inspect(const fs::path& path, PluginDescriptor* descriptor) {
  try {
    return inspect_or_throw(path, descriptor);
  } catch (const std::bad_alloc&) {
    descriptor->error = "cannot load: out of memory while reading or loading it";
  } catch (const std::length_error&) {
    descriptor->error = "cannot load: out of memory while reading or loading it";
  }
  return nullptr;
}

}  // namespace

PluginRegistry::PluginRegistry(std::vector<fs::path> search_path) : search_path_(std::move(search_path)) {}

PluginRegistry::~PluginRegistry() = default;

std::vector<fs::path> PluginRegistry::standard_search_path(const std::vector<fs::path>& explicit_paths,
                                                           const std::vector<fs::path>& bank_paths) {
  std::vector<fs::path> candidates = explicit_paths;
  candidates.insert(candidates.end(), bank_paths.begin(), bank_paths.end());
  for (const fs::path& p : split_path_list(std::getenv("SKIDIMM_PLUGIN_PATH"))) candidates.push_back(p);
  // Relocatable install (and the build tree, which mirrors it): <bin>/../lib/skidimm/plugins.
  try {
    candidates.push_back(fs::path(boost::dll::program_location().parent_path().string()) / ".." /
                         SKIDIMM_PLUGIN_SUBDIR);
  } catch (const std::exception&) {
    // No /proc: rely on the configured install prefix alone.
  }
  if (std::string(SKIDIMM_INSTALLED_PLUGIN_DIR).size() > 0) candidates.emplace_back(SKIDIMM_INSTALLED_PLUGIN_DIR);

  std::vector<fs::path> out;
  std::set<fs::path> seen;
  for (const fs::path& candidate : candidates) {
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(candidate, ec);
    if (ec) canonical = candidate.lexically_normal();
    if (seen.insert(canonical).second) out.push_back(canonical);
  }
  return out;
}

void PluginRegistry::scan() {
  if (scanned_) return;
  scanned_ = true;
  std::set<std::string> names_seen;
  for (std::size_t entry = 0; entry < search_path_.size(); ++entry) {
    const fs::path& location = search_path_[entry];
    std::error_code ec;
    std::vector<fs::path> files;
    if (fs::is_directory(location, ec)) {
      for (const fs::directory_entry& item : fs::directory_iterator(location, ec)) {
        // Not only regular files: a FIFO or a device named like a library is
        // listed as rejected, with what it is (inspect never opens it).
        if (is_shared_library(item.path()) && !item.is_directory(ec)) files.push_back(item.path());
      }
      std::sort(files.begin(), files.end());
    } else if (fs::exists(location, ec)) {
      files.push_back(location);  // a single plugin file named explicitly
    } else {
      continue;  // a missing directory on the search path is normal (e.g. no install)
    }
    std::map<std::string, std::size_t> names_in_entry;  // name -> its first descriptor in this entry
    for (const fs::path& file : files) {
      PluginDescriptor descriptor;
      std::shared_ptr<boost::dll::shared_library> library = inspect(file, &descriptor);
      if (library != nullptr) {
        descriptor.shadowed = names_seen.count(descriptor.name) != 0;  // claimed by an earlier entry
        const auto first = names_in_entry.emplace(descriptor.name, descriptors_.size());
        if (!first.second) {
          PluginDescriptor& other = descriptors_[first.first->second];
          descriptor.duplicate_of = other.path;
          if (other.duplicate_of.empty()) other.duplicate_of = file;
        }
      }
      descriptors_.push_back(std::move(descriptor));
      libraries_.push_back(std::move(library));
      search_entry_of_.push_back(entry);
    }
    for (const auto& claimed : names_in_entry) names_seen.insert(claimed.first);
  }
}

const std::vector<PluginDescriptor>& PluginRegistry::plugins() {
  scan();
  return descriptors_;
}

const PluginDescriptor& PluginRegistry::find(const std::string& name) {
  scan();
  const PluginDescriptor* match = nullptr;
  std::size_t match_entry = 0;
  for (std::size_t i = 0; i < descriptors_.size(); ++i) {
    const PluginDescriptor& d = descriptors_[i];
    if (d.name != name) continue;
    if (!d.error.empty()) {
      throw PluginError("plugin '" + name + "' at " + d.path.string() + " is unusable: " + d.error);
    }
    if (match == nullptr) {
      match = &d;
      match_entry = search_entry_of_[i];
    } else if (search_entry_of_[i] == match_entry) {
      throw PluginError("two plugins are named '" + name + "': " + match->path.string() + " and " + d.path.string() +
                        "; remove one or give it another name");
    }
  }
  if (match != nullptr) return *match;

  std::string message = "no plugin named '" + name + "' on the search path [";
  for (std::size_t i = 0; i < search_path_.size(); ++i) {
    std::error_code ec;
    message += (i ? ", " : "") + search_path_[i].string() + (fs::exists(search_path_[i], ec) ? "" : " (missing)");
  }
  message += "]";
  std::string available;
  for (const PluginDescriptor& d : descriptors_) {
    if (d.error.empty() && !d.shadowed) available += (available.empty() ? "" : ", ") + d.name;
  }
  message += available.empty() ? "; no plugins were found there" : "; found: " + available;
  for (const PluginDescriptor& d : descriptors_) {
    if (!d.error.empty()) message += "\n  skipped " + d.path.string() + ": " + d.error;
  }
  message += "\n  (add a directory with --plugin-path, the bank's plugin_paths or SKIDIMM_PLUGIN_PATH)";
  throw PluginError(message);
}

ModelHandle PluginRegistry::create(const std::string& name, const sdk::ParameterSet& params) {
  const PluginDescriptor& descriptor = find(name);
  const std::size_t index = static_cast<std::size_t>(&descriptor - descriptors_.data());
  std::shared_ptr<boost::dll::shared_library> library = libraries_[index];
  auto& factory = library->get_alias<sdk::MotionModelFactory>(sdk::kFactorySymbol);
  std::string error;
  sdk::MotionModel* raw = factory(params, &error);
  if (raw == nullptr) {
    throw PluginError("plugin '" + name + "' (" + descriptor.path.string() + ") rejected its parameters: " +
                      (error.empty() ? "its factory returned no model and gave no reason" : error));
  }
  // The deleter owns a reference to the library: the object's code (its
  // destructor, its vtable) stays mapped until the object is gone.
  ModelHandle model(raw, [library](sdk::MotionModel* m) { delete m; });
  // A plugin that declares its states, inputs and outputs must create models that have them.
  auto check = [&](const char* what, const std::vector<PluginVariable>& declared,
                   const std::vector<std::string>& actual, bool states) {
    if (declared.empty()) return;
    bool same = declared.size() == actual.size();
    for (std::size_t i = 0; same && i < declared.size(); ++i) {
      same = declared[i].name == actual[i] && (!states || declared[i].is_angle == model->is_angle(static_cast<int>(i)));
    }
    if (same) return;
    std::string expected, got;
    for (std::size_t i = 0; i < declared.size(); ++i) {
      expected += (i ? ", " : "") + declared[i].name + (declared[i].is_angle ? " (angle)" : "");
    }
    for (std::size_t i = 0; i < actual.size(); ++i) {
      got += (i ? ", " : "") + actual[i] + (states && model->is_angle(static_cast<int>(i)) ? " (angle)" : "");
    }
    throw PluginError("plugin '" + name + "' (" + descriptor.path.string() + ") declares " + what + " [" + expected +
                      "] in its PluginInfo, but its model has [" + got + "]");
  };
  check("states", descriptor.states, model->state_names(), true);
  check("inputs", descriptor.inputs, model->input_names(), false);
  check("outputs", descriptor.outputs, model->output_names(), false);
  return model;
}

}  // namespace skidimm
