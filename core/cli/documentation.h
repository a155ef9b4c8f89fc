// Where the tool's help points a reader: the documentation and the bundled
// banks and example logs, as installed next to the executable
// (<prefix>/bin/skidimm: <prefix>/share/doc/skidimm, <prefix>/share/skidimm),
// or, run from a build tree, the source tree's own (docs/..., configs/...,
// relative to its root, as the README gives them).
#ifndef SKIDIMM_CLI_DOCUMENTATION_H_
#define SKIDIMM_CLI_DOCUMENTATION_H_

#include <string>

namespace skidimm {
namespace cli {

// A page of the documentation: documentation_path("docs/cli.md").
std::string documentation_path(const std::string& page);

// A bundled file: bundled_path("configs/ltc_terrains.yaml").
std::string bundled_path(const std::string& file);

}  // namespace cli
}  // namespace skidimm

#endif  // SKIDIMM_CLI_DOCUMENTATION_H_
