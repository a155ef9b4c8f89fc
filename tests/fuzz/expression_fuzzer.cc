// Fuzzes the column expression language (expression.h): the input is an
// expression's text. It is parsed as a plain expression and with the log
// reader's aggregates cut out (mean, std, rms, diff_std); whatever parses is evaluated
// at a few points (zero, negative, huge, NaN).
//
// Bad text must end in an ExpressionError whose message is short and
// printable; a text that parses may only name variables of the language
// (letters, digits, '_', not starting with '_' or a digit; or a bag's topic
// path, starting with '/') and must evaluate
// without throwing. Any other exception, a crash, a hang or a sanitizer
// report is a finding.

#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "skidimm/config/expression.h"

namespace {

[[noreturn]] void finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "expression_fuzzer: %s: %s\n", what, detail.c_str());
  std::abort();
}

void check_message(const std::string& message) {
  // A message quotes at most a short excerpt (each byte escaped to at most 4).
  if (message.size() > 1200) finding("message too long", message.substr(0, 200));
  for (unsigned char c : message) {
    if ((c < 0x20 && c != '\t') || c == 0x7f) finding("raw control byte in the message", message.substr(0, 200));
  }
}

void check_names(const std::vector<std::string>& names, const std::string& text) {
  for (const std::string& name : names) {
    if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_' || name[0] == '/')) {
      finding("a variable that is not a name", name + " in " + text.substr(0, 200));
    }
  }
}

void evaluate_at_a_few_points(const skidimm::Expression& e) {
  const double points[] = {0.0, -1.5, 1e300, std::numeric_limits<double>::quiet_NaN(),
                           std::numeric_limits<double>::infinity()};
  std::vector<double> values(e.variables().size());
  for (double p : points) {
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = p * static_cast<double>(i + 1);
    (void)e.evaluate(values.data());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const skidimm::Expression e(text);
    check_names(e.variables(), text);
    for (const std::string& name : e.variables()) {
      if (name[0] == '_') finding("a reserved name accepted", name);
    }
    evaluate_at_a_few_points(e);
  } catch (const skidimm::ExpressionError& error) {
    check_message(error.what());
  }
  try {
    const skidimm::Expression::WithCalls cut = skidimm::Expression::cut_calls(text, {"mean", "std", "rms", "diff_std"});
    if (cut.outer->variables().size() != cut.calls.size() + cut.names_outside.size()) {
      finding("outer variables do not match the calls and names", text.substr(0, 200));
    }
    check_names(cut.names_outside, text);
    evaluate_at_a_few_points(*cut.outer);
    for (const skidimm::Expression::Call& call : cut.calls) {
      // The reader parses each argument that is not a column's exact name.
      try {
        const skidimm::Expression inner(call.argument);
        evaluate_at_a_few_points(inner);
      } catch (const skidimm::ExpressionError& error) {
        check_message(error.what());
      }
    }
  } catch (const skidimm::ExpressionError& error) {
    check_message(error.what());
  }
  return 0;
}
