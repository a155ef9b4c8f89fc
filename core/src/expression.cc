#include "skidimm/expression.h"

#include <muParser.h>

#include <cctype>
#include <limits>
#include <utility>

#include "topic_path_names.h"

namespace skidimm {

Expression::Expression(const std::string& text) : text_(text), parser_(std::make_unique<mu::Parser>()) {
  try {
    // A bag's topic paths are names (topic_path_names.h).
    std::vector<std::string> paths;
    const std::string parsed = topic_path_names::replace(text, &paths);
    parser_->SetExpr(parsed);
    // GetUsedVar parses the whole expression (syntax errors throw here) and
    // collects the identifiers that are neither functions nor constants.
    std::vector<std::string> names;
    for (const auto& entry : parser_->GetUsedVar()) names.push_back(entry.first);
    for (const std::string& name : names) variables_.push_back(topic_path_names::original(name, paths));
    // muparser lists them sorted; keep that order, it is as good as any and stable.
    slots_ = std::make_unique<double[]>(variables_.size() + 1);
    for (std::size_t i = 0; i < variables_.size(); ++i) {
      slots_[i] = 0.0;
      parser_->DefineVar(names[i], &slots_[i]);
    }
    parser_->SetExpr(parsed);
    parser_->Eval();  // compiles to bytecode now, so evaluate() never meets a parse error
  } catch (const mu::Parser::exception_type& e) {
    std::string message = e.GetMsg();
    if (!message.empty() && message.back() == '.') message.pop_back();
    throw ExpressionError("cannot parse \"" + text + "\": " + message);
  }
}

Expression::~Expression() = default;
Expression::Expression(Expression&&) noexcept = default;
Expression& Expression::operator=(Expression&&) noexcept = default;

double Expression::evaluate(const double* values) const {
  for (std::size_t i = 0; i < variables_.size(); ++i) slots_[i] = values[i];
  try {
    return parser_->Eval();
  } catch (const mu::Parser::exception_type&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

bool Expression::is_identifier(const std::string& name) {
  if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
  for (unsigned char c : name) {
    if (!(std::isalnum(c) || c == '_')) return false;
  }
  return true;
}

}  // namespace skidimm
