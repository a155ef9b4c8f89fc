// `skidimm fit` says what it fitted on: it counts logs (files), not the
// segments a truth column cuts them into, and writes a model's parameters in
// the order of its own table.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli/run_skidimm.h"
#include "core/temp_files.h"

namespace {

using skidimm_test::column;
using skidimm_test::csv_text;
using skidimm_test::read_csv;
using skidimm_test::Result;
using skidimm_test::run_skidimm;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

const std::string kSource = SKIDIMM_SOURCE_DIR;
const std::string kPlugins = SKIDIMM_PLUGIN_DIR;

TEST(FitCommand, CountsLogsNotTheSegmentsTheirTruthCutsThemInto) {
  // The switching log with its first 5 s relabelled asphalt: asphalt is then
  // the truth of two stretches of one file.
  auto rows = read_csv(kSource + "/configs/examples/ltc_switching.csv");
  const int t = column(rows[0], "t"), mode = column(rows[0], "mode");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (std::stod(rows[i][static_cast<std::size_t>(t)]) < 5.0) rows[i][static_cast<std::size_t>(mode)] = "asphalt";
  }
  const fs::path dir = test_directory();
  const fs::path first = write_file(dir / "first.csv", csv_text(rows));
  const fs::path second = write_file(dir / "second.csv", csv_text(rows));
  const Result r = run_skidimm("fit --bank " + kSource + "/configs/ltc_terrains.yaml --plugin-path " + kPlugins +
                               " --objective window --window 0.5 --log " + first.string() + " --log " + second.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("mode 'asphalt': 2 log(s) (4 segments), "));
  EXPECT_THAT(r.err, HasSubstr("mode 'grass': 2 log(s), "));
  EXPECT_THAT(r.out, HasSubstr("fitted by skidimm fit (window 0.5 s, huber) from 2 log(s); "));
  EXPECT_THAT(r.out, ::testing::Not(HasSubstr("from 4 log(s)")));
}

// The parameter names `skidimm plugins` lists for `plugin`, in its table's order.
std::vector<std::string> parameter_table(const std::string& plugin) {
  const Result r = run_skidimm("plugins --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> names;
  const std::size_t start = r.out.find("\n" + plugin + " ");
  const std::size_t table = r.out.find("    parameters:\n", start);
  const std::size_t end = r.out.find("\n\n", table);
  static const std::regex row(R"(^      (\w+) \()");
  std::istringstream lines(r.out.substr(table, end - table));
  std::string line;
  while (std::getline(lines, line)) {
    std::smatch match;
    if (std::regex_search(line, match, row)) names.push_back(match[1]);
  }
  return names;
}

TEST(FitCommand, WritesParametersInTheOrderOfTheModelsTable) {
  const std::vector<std::string> table = parameter_table("stc_sided");
  ASSERT_GE(table.size(), 7u);
  const fs::path entries = test_directory() / "entries.yaml";
  const Result r = run_skidimm("fit --bank " + kSource + "/configs/stc_sided4.yaml --plugin-path " + kPlugins +
                               " --objective window --window 1 --hold-unexcited --log " + kSource +
                               "/configs/examples/stc_switching.csv --output-entry " + entries.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = skidimm_test::read_file(entries);
  const std::size_t params = text.find("params: {");
  ASSERT_NE(params, std::string::npos) << text;
  std::vector<std::string> written;
  static const std::regex key(R"(([A-Za-z_]\w*): )");
  const std::string line = text.substr(params + 9, text.find('}', params) - params - 9);
  for (std::sregex_iterator it(line.begin(), line.end(), key), end; it != end; ++it) written.push_back((*it)[1]);
  std::vector<std::string> expected;
  for (const std::string& name : table) {
    if (std::find(written.begin(), written.end(), name) != written.end()) expected.push_back(name);
  }
  ASSERT_EQ(written.size(), 7u) << line;
  EXPECT_EQ(written, expected) << line;
}

}  // namespace
