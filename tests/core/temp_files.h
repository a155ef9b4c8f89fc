// Temporary files for tests, under GoogleTest's temp directory.
#ifndef SKIDIMM_TESTS_CORE_TEMP_FILES_H_
#define SKIDIMM_TESTS_CORE_TEMP_FILES_H_

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace skidimm_test {

// A fresh directory per test: <tmp>/skidimm_<suite>_<test>.
inline std::filesystem::path test_directory() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) /
                              ("skidimm_" + std::string(info->test_suite_name()) + "_" + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline std::filesystem::path write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// `text` with its first `from` replaced by `to` (std::out_of_range if there is none).
inline std::string replace_first(std::string text, const std::string& from, const std::string& to) {
  return text.replace(text.find(from), from.size(), to);
}

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_CORE_TEMP_FILES_H_
