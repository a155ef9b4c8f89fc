// Where the Python module finds plugins without configuration, like the
// installed `skidimm` tool does next to itself.
#ifndef SKIDIMM_PYTHON_PLUGIN_LOCATION_H_
#define SKIDIMM_PYTHON_PLUGIN_LOCATION_H_

#include <filesystem>
#include <vector>

namespace skidimm {
namespace python {

// The bundled plugin directory relative to this module: the build tree
// mirrors the install tree (python/CMakeLists.txt), so
// <package dir>/SKIDIMM_PYTHON_PLUGIN_DIR_RELATIVE is <build>/lib/skidimm/plugins
// in a build tree and <prefix>/lib/skidimm/plugins in an install.
std::filesystem::path module_plugin_directory();

// The search path for a bank (plugin_registry.h, first match wins):
//   1. `explicit_paths` (plugin_paths=..., like --plugin-path),
//   2. the bank's `plugin_paths`,
//   3. $SKIDIMM_PLUGIN_PATH,
//   4. the plugins next to this module (module_plugin_directory()),
//   5. the executable's and the configured install prefix's, as the tool's
//      (for Python, the executable is the interpreter: harmless when absent).
std::vector<std::filesystem::path> plugin_search_path(const std::vector<std::filesystem::path>& explicit_paths,
                                                      const std::vector<std::filesystem::path>& bank_paths);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_PLUGIN_LOCATION_H_
