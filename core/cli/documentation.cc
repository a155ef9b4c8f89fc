#include "documentation.h"

#include <filesystem>
#include <system_error>

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

namespace {

// <prefix>/share/... next to <prefix>/bin/skidimm, when it is there.
fs::path installed(const fs::path& relative) {
  std::error_code ec;
  const fs::path executable = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const fs::path directory = (executable.parent_path().parent_path() / relative).lexically_normal();
  return fs::is_directory(directory, ec) ? directory : fs::path();
}

}  // namespace

std::string documentation_path(const std::string& page) {
  static const fs::path directory = installed(SKIDIMM_INSTALL_DOCDIR);
  return directory.empty() ? page : (directory / page).string();
}

std::string bundled_path(const std::string& file) {
  static const fs::path directory = installed(SKIDIMM_INSTALL_DATADIR "/skidimm");
  return directory.empty() ? file : (directory / file).string();
}

}  // namespace cli
}  // namespace skidimm
