#include "plugin_location.h"

#include <dlfcn.h>

#include <cstdlib>
#include <sstream>
#include <string>

#include "skidimm/engine/plugin_registry.h"

#ifndef SKIDIMM_PYTHON_PLUGIN_DIR_RELATIVE
#define SKIDIMM_PYTHON_PLUGIN_DIR_RELATIVE "../../../skidimm/plugins"
#endif

namespace skidimm {
namespace python {

namespace fs = std::filesystem;

fs::path module_plugin_directory() {
  Dl_info info{};
  // Any address inside this module names the module's file.
  if (dladdr(reinterpret_cast<void*>(&module_plugin_directory), &info) == 0 || info.dli_fname == nullptr) return {};
  std::error_code ec;
  fs::path module = fs::weakly_canonical(fs::path(info.dli_fname), ec);
  if (ec) module = fs::path(info.dli_fname);
  return (module.parent_path() / SKIDIMM_PYTHON_PLUGIN_DIR_RELATIVE).lexically_normal();
}

std::vector<fs::path> plugin_search_path(const std::vector<fs::path>& explicit_paths,
                                         const std::vector<fs::path>& bank_paths) {
  // standard_search_path puts the explicit paths, then the "bank" paths, then
  // $SKIDIMM_PLUGIN_PATH, the executable's and the prefix's, dropping
  // duplicates; passing ours as the bank's last entries puts them before the
  // last two.
  std::vector<fs::path> before_installed = bank_paths;
  if (const char* list = std::getenv("SKIDIMM_PLUGIN_PATH")) {
    std::stringstream stream(list);
    std::string item;
    while (std::getline(stream, item, ':')) {
      if (!item.empty()) before_installed.emplace_back(item);
    }
  }
  const fs::path here = module_plugin_directory();
  if (!here.empty()) before_installed.push_back(here);
  return PluginRegistry::standard_search_path(explicit_paths, before_installed);
}

}  // namespace python
}  // namespace skidimm
