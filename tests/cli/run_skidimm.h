// Running the `skidimm` executable from a test, and reading what it wrote.
#ifndef SKIDIMM_TESTS_CLI_RUN_SKIDIMM_H_
#define SKIDIMM_TESTS_CLI_RUN_SKIDIMM_H_

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "skidimm/log_io.h"

namespace skidimm_test {

struct Result {
  int exit_code;
  std::string out;
  std::string err;
};

// `skidimm <arguments>` through the shell, standard input from /dev/null.
inline Result run_skidimm(const std::string& arguments) {
  // One capture directory per test process: ctest runs the tests of a file in parallel.
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) /
      ("skidimm_cli_capture_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string command = std::string(SKIDIMM_EXECUTABLE) + " " + arguments + " > " + (dir / "out").string() +
                              " 2> " + (dir / "err").string() + " < /dev/null";
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(dir / "out"), read_file(dir / "err")};
}

// A CSV file's rows, the header first.
inline std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  skidimm::CsvReader reader(path);
  std::vector<std::vector<std::string>> rows{reader.header()};
  std::vector<std::string> fields;
  while (reader.next(&fields)) rows.push_back(fields);
  return rows;
}

// The index of column `name` in `header` (a test failure if absent).
inline int column(const std::vector<std::string>& header, const std::string& name) {
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == name) return static_cast<int>(i);
  }
  ADD_FAILURE() << "no column " << name;
  return 0;
}

// Rows as CSV text.
inline std::string csv_text(const std::vector<std::vector<std::string>>& rows) {
  std::string text;
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) text += (i ? "," : "") + row[i];
    text += "\n";
  }
  return text;
}

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_CLI_RUN_SKIDIMM_H_
