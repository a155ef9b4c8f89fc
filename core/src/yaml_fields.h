// Typed access to YAML nodes that turns every mismatch into a ConfigError
// naming the file, the line and the field ("modes[2].Q").
#ifndef SKIDIMM_CORE_SRC_YAML_FIELDS_H_
#define SKIDIMM_CORE_SRC_YAML_FIELDS_H_

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/errors.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace internal {

class YamlFields {
 public:
  explicit YamlFields(std::string file) : file_(std::move(file)) {}

  const std::string& file() const { return file_; }

  // Loads the file as a YAML mapping. `kind` names it in messages ("bank",
  // "scenario"): a missing file, a syntax error (with its line) and a
  // non-mapping document are ConfigErrors.
  YAML::Node load_mapping(const std::string& kind) const {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file_, ec)) {
      // A pipe (<(...)) exists, but is read again (the bank's writers copy it): say what it is.
      const bool exists = std::filesystem::exists(file_, ec);
      throw ConfigError(file_, 0, "",
                        !exists ? "no such " + kind + " file"
                        : std::filesystem::is_directory(file_, ec)
                            ? "is a directory, not a " + kind + " file"
                            : "is not a regular file (a pipe or a device): give the " + kind + " as a file");
    }
    YAML::Node root;
    try {
      root = YAML::LoadFile(file_);
    } catch (const YAML::ParserException& e) {
      throw ConfigError(file_, e.mark.line + 1, "", "malformed YAML: " + e.msg + csv_hint(kind));
    } catch (const YAML::Exception& e) {
      throw ConfigError(file_, 0, "", std::string("cannot read YAML: ") + e.what());
    }
    if (!root.IsMap()) throw ConfigError(file_, 1, "", "a " + kind + " file must be a YAML mapping" + csv_hint(kind));
    std::set<int> visited;
    reject_duplicate_keys(root, "", &visited);
    return root;
  }

  // A log given where a YAML file goes (--bank and --input swapped) parses
  // as one string or fails: "; this looks like a CSV log ..." when the
  // file's first line does (commas, and no "key: value"), else "".
  std::string csv_hint(const std::string& kind) const {
    std::ifstream in(file_);
    std::string first;
    std::getline(in, first);
    if (first.find(',') == std::string::npos || first.find(": ") != std::string::npos) return "";
    return "; this looks like a CSV log, not a " + kind + " file" +
           (kind == "bank" ? " (were a log and the bank given the other way round?)" : "");
  }

  // yaml-cpp keeps every entry of a mapping but looks keys up by the first,
  // so a repeated key would silently lose its second value: an error instead,
  // anywhere in the document.
  // Each node of the text is checked once (by its position), so aliases that
  // repeat a node a billion times cost nothing.
  void reject_duplicate_keys(const YAML::Node& node, const std::string& field, std::set<int>* visited) const {
    if ((node.IsMap() || node.IsSequence()) && !node.Mark().is_null() && !visited->insert(node.Mark().pos).second) {
      return;
    }
    if (node.IsMap()) {
      std::vector<std::pair<std::string, int>> seen;
      for (const auto& entry : node) {
        const std::string key = entry.first.IsScalar() ? entry.first.Scalar() : std::string("?");
        const std::string path = field.empty() ? key : field + "." + key;
        for (const auto& [other, line] : seen) {
          if (other == key) {
            fail(entry.first, path,
                 "appears twice in one mapping (first on line " + std::to_string(line) +
                     "); a repeated key would silently lose one of its values");
          }
        }
        seen.emplace_back(key, line_of(entry.first));
        reject_duplicate_keys(entry.second, path, visited);
      }
    } else if (node.IsSequence()) {
      for (std::size_t i = 0; i < node.size(); ++i) {
        reject_duplicate_keys(node[i], field + "[" + std::to_string(i) + "]", visited);
      }
    }
  }

  static int line_of(const YAML::Node& node) { return node.Mark().is_null() ? 0 : node.Mark().line + 1; }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& field, const std::string& message) const {
    throw ConfigError(file_, line_of(node), field, message);
  }
  [[noreturn]] void fail_at(int line, const std::string& field, const std::string& message) const {
    throw ConfigError(file_, line, field, message);
  }

  // A required child of a map.
  YAML::Node required(const YAML::Node& map, const std::string& key, const std::string& field) const {
    if (!map.IsMap()) fail(map, field.empty() ? key : field, "expected a mapping");
    YAML::Node child = map[key];
    if (!child) {
      const std::string name = field.empty() ? key : field + "." + key;
      fail(map, name, "missing (required)");
    }
    return child;
  }

  // Fails on keys outside `allowed`: typos must not be silently ignored.
  void check_keys(const YAML::Node& map, const std::vector<std::string>& allowed, const std::string& field) const {
    if (!map.IsMap()) fail(map, field, "expected a mapping");
    for (const auto& entry : map) {
      const std::string key = this->key(entry.first, field);
      bool known = false;
      for (const std::string& a : allowed) known = known || a == key;
      if (!known) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(entry.first, (field.empty() ? "" : field + ".") + key, "unknown key (expected one of: " + list + ")");
      }
    }
  }

  // A mapping's key: a scalar. (`as<std::string>()` threw yaml-cpp's own
  // exception, without the file, for a key that is a tag alone, `{!x: 1}`,
  // or a sequence: found by the scenario fuzzer.)
  std::string key(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) {
      fail(node, field,
           std::string("expected a name as the key, got ") +
               (node.IsNull() ? "nothing (a tag alone?)" : node.IsMap() ? "a mapping" : "a sequence"));
    }
    return node.Scalar();
  }

  std::string string(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fail(node, field, "expected a string");
    return node.Scalar();
  }

  double number(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fail(node, field, "expected a number");
    try {
      return node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, field, "expected a number, got '" + node.Scalar() + "'");
    }
  }

  std::vector<std::string> string_list(const YAML::Node& node, const std::string& field) const {
    if (!node.IsSequence()) fail(node, field, "expected a list of names");
    std::vector<std::string> out;
    for (std::size_t i = 0; i < node.size(); ++i) {
      out.push_back(string(node[i], field + "[" + std::to_string(i) + "]"));
    }
    return out;
  }

  Eigen::VectorXd vector(const YAML::Node& node, const std::string& field) const {
    if (node.IsScalar()) return Eigen::VectorXd::Constant(1, number(node, field));
    if (!node.IsSequence()) fail(node, field, "expected a list of numbers");
    Eigen::VectorXd out(node.size());
    for (std::size_t i = 0; i < node.size(); ++i) {
      out[static_cast<Eigen::Index>(i)] = number(node[i], field + "[" + std::to_string(i) + "]");
    }
    return out;
  }

  // A number (1x1), a flat list (n x 1) or a list of equal-length rows.
  Eigen::MatrixXd matrix(const YAML::Node& node, const std::string& field) const {
    if (node.IsScalar()) return Eigen::MatrixXd::Constant(1, 1, number(node, field));
    if (!node.IsSequence() || node.size() == 0) fail(node, field, "expected a number, a list or a list of rows");
    if (!node[0].IsSequence()) return vector(node, field);
    const std::size_t rows = node.size();
    const std::size_t cols = node[0].size();
    Eigen::MatrixXd out(rows, cols);
    for (std::size_t r = 0; r < rows; ++r) {
      const std::string row_field = field + "[" + std::to_string(r) + "]";
      if (!node[r].IsSequence()) fail(node[r], row_field, "expected a row of numbers, as row 0 is");
      if (node[r].size() != cols) {
        // Either row may be the wrong one: say both lengths.
        fail(node[r], row_field,
             "this row has " + std::to_string(node[r].size()) + " numbers and row 0 has " + std::to_string(cols) +
                 ": every row of a matrix needs as many");
      }
      for (std::size_t c = 0; c < cols; ++c) {
        out(r, c) = number(node[r][c], row_field + "[" + std::to_string(c) + "]");
      }
    }
    return out;
  }

  // A model parameter: a matrix (a number, a list or a list of rows of
  // numbers), or text (a string, or a list of strings). A quoted scalar is
  // always text, so `["1"]` is the text "1" and `[1]` the number.
  void parameter(const YAML::Node& node, const std::string& key, const std::string& field,
                 sdk::ParameterSet* params) const {
    auto is_text = [](const YAML::Node& n) {
      if (!n.IsScalar()) return false;
      if (n.Tag() == "!") return true;  // quoted
      double ignored;
      return !YAML::convert<double>::decode(n, ignored);
    };
    bool text = is_text(node);
    if (node.IsSequence() && node.size() > 0) {
      bool any_text = false, all_scalars = true;
      for (std::size_t i = 0; i < node.size(); ++i) {
        any_text = any_text || is_text(node[i]);
        all_scalars = all_scalars && node[i].IsScalar();
      }
      if (any_text && !all_scalars) fail(node, field, "expected a list of numbers, of rows of numbers, or of strings");
      text = any_text;
    }
    if (!text) {
      params->set(key, matrix(node, field));
      return;
    }
    std::vector<std::string> values;
    if (node.IsScalar()) {
      values.push_back(node.Scalar());
    } else {
      for (std::size_t i = 0; i < node.size(); ++i) values.push_back(node[i].Scalar());
    }
    params->set_text(key, std::move(values));
  }

  // A rows x cols matrix, exactly.
  Eigen::MatrixXd matrix(const YAML::Node& node, int rows, int cols, const std::string& field) const {
    Eigen::MatrixXd m = matrix(node, field);
    if (m.rows() != rows || m.cols() != cols) {
      fail(node, field,
           "expected a " + std::to_string(rows) + "x" + std::to_string(cols) + " matrix, got " +
               std::to_string(m.rows()) + "x" + std::to_string(m.cols()));
    }
    return m;
  }

  // An n x n covariance: a full matrix, {diagonal: [...]} or {std: [...]}
  // (standard deviations, squared onto the diagonal).
  Eigen::MatrixXd covariance(const YAML::Node& node, int n, const std::string& field) const {
    if (node.IsMap()) {
      check_keys(node, {"diagonal", "std"}, field);
      if (node.size() != 1) fail(node, field, "give exactly one of 'diagonal' or 'std'");
      const bool is_std = static_cast<bool>(node["std"]);
      const YAML::Node values = is_std ? node["std"] : node["diagonal"];
      const std::string sub = field + (is_std ? ".std" : ".diagonal");
      Eigen::VectorXd d = vector(values, sub);
      if (d.size() != n)
        fail(values, sub, "expected " + std::to_string(n) + " values, got " + std::to_string(d.size()));
      if (is_std) {
        if ((d.array() < 0.0).any()) fail(values, sub, "standard deviations cannot be negative");
        d = d.array().square();
      }
      return d.asDiagonal();
    }
    return matrix(node, n, n, field);
  }

 private:
  std::string file_;
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_YAML_FIELDS_H_
