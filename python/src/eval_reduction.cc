// The CLI's eval command, compiled here so that its reduction (summarize,
// json_summary, print_table, in an unnamed namespace there) is the one the
// bindings use. This is a stopgap: those functions belong in the library
// (requested in the report of issue 14); until they move, including the
// file keeps Python's figures identical to the CLI's by construction rather
// than by a copy that could drift. Nothing else of the CLI is linked.
#include "eval_reduction.h"

#include <sstream>

#include "eval_command.cc"  // NOLINT(bugprone-suspicious-include)

namespace skidimm {
namespace python {

namespace {

std::vector<const evaluation::LogResult*> pointers(const std::vector<evaluation::LogResult>& logs) {
  std::vector<const evaluation::LogResult*> out;
  for (const evaluation::LogResult& l : logs) out.push_back(&l);
  return out;
}

}  // namespace

std::string eval_group_name(const std::string& argument) { return cli::group_name(argument); }

// As the JSON branch of cli::eval.
std::string eval_json(const std::vector<EvalGroup>& groups, const std::vector<std::string>& states) {
  std::vector<const evaluation::LogResult*> all;
  for (const EvalGroup& g : groups) {
    for (const evaluation::LogResult& l : g.logs) all.push_back(&l);
  }
  const cli::Summary overall = cli::summarize(all, states.size());
  std::ostringstream out;
  out << "{\"overall\": " << cli::json_summary(overall, states, all) << ", \"groups\": {";
  for (std::size_t i = 0; i < groups.size(); ++i) {
    const std::vector<const evaluation::LogResult*> logs = pointers(groups[i].logs);
    out << (i ? ", " : "") << cli::json_string(groups[i].name) << ": "
        << cli::json_summary(cli::summarize(logs, states.size()), states, logs);
  }
  out << "}, \"logs\": {";
  for (std::size_t i = 0; i < all.size(); ++i) {
    out << (i ? ", " : "") << cli::json_string(all[i]->name) << ": "
        << cli::json_summary(cli::summarize({all[i]}, states.size()), states, {all[i]});
  }
  out << "}}\n";
  return out.str();
}

// As the table branch of cli::eval.
std::string eval_table(const std::vector<EvalGroup>& groups, const std::vector<std::string>& classes,
                       const std::vector<std::string>& states, const DecisionConfig& decision) {
  const std::string decision_made = cli::decision_settings_text(decision);
  std::vector<const evaluation::LogResult*> all;
  for (const EvalGroup& g : groups) {
    for (const evaluation::LogResult& l : g.logs) all.push_back(&l);
  }
  std::ostringstream out;
  if (groups.size() > 1) {
    for (const EvalGroup& g : groups) {
      const std::vector<const evaluation::LogResult*> logs = pointers(g.logs);
      cli::print_table(out, g.name, cli::summarize(logs, states.size()), classes, states, logs.size() == 1, logs,
                       decision_made);
    }
  }
  if (!groups.empty()) {
    cli::print_table(out, groups.size() > 1 ? "all" : groups[0].name, cli::summarize(all, states.size()), classes,
                     states, all.size() <= 3, all, decision_made);
  }
  return out.str();
}

}  // namespace python
}  // namespace skidimm
