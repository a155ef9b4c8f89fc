// Expression: an arithmetic expression of named values, such as a bank's
// `columns: {inputs: {abs_dv: "abs(velR - velL)"}}`.
//
// The language is closed, and small:
//  * numbers (decimal, optionally with an exponent: 2, 0.5, .5, 1e-3);
//  * names: letters, digits and '_', not starting with a digit or '_'; each
//    is a variable (a log column, an input), listed by variables();
//  * operators + - * / ^ (power), unary - and +, comparisons < <= > >= ==
//    != (1 or 0), && and ||, the conditional c ? a : b, and parentheses;
//  * functions abs, sign, sqrt, exp, log (natural), log10, sin, cos, of one
//    argument, and min, max of one or more, separated by ','.
// Nothing else: no assignment ('=', '+=', ...), no list of expressions
// ("a, b"), no constants or other functions, no character outside the
// tokens above (a NUL, a control character, a byte of UTF-8). Every token is
// checked here before muparser (Debian libmuparser-dev), which parses and
// evaluates the expression, sees the text, so nothing of muparser's larger
// language is reachable. At most kMaxLength bytes and kMaxDepth nested
// parentheses.
//
// Errors are ExpressionErrors whose what() says what is wrong, at which
// character, and quotes at most a short excerpt of the text (excerpt()),
// never all of it. Nothing is evaluated while parsing, so an expression is
// checked before any data is read.
//
// One Expression is used from one thread at a time (muparser keeps a stack).
#ifndef SKIDIMM_CONFIG_EXPRESSION_H_
#define SKIDIMM_CONFIG_EXPRESSION_H_

#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace mu {
class Parser;
}

namespace skidimm {

// A syntax error. what() says what is wrong and at which character.
class ExpressionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class Expression {
 public:
  static constexpr std::size_t kMaxLength = 1024;
  static constexpr int kMaxDepth = 32;

  // Parses `text`. Throws ExpressionError.
  explicit Expression(const std::string& text);
  ~Expression();
  Expression(Expression&&) noexcept;
  Expression& operator=(Expression&&) noexcept;
  Expression(const Expression&) = delete;
  Expression& operator=(const Expression&) = delete;

  const std::string& text() const { return text_; }
  // The names, in order of first use.
  const std::vector<std::string>& variables() const { return variables_; }

  // The value for variables()[i] = values[i]. NaN or inf when the arithmetic
  // gives them (log(0), 0/0); never throws.
  double evaluate(const double* values) const;

  // True if `name` is made of letters, digits and '_' and does not start
  // with a digit. Other column names can only be used whole, as a plain
  // column; so can names starting with '_', which the language reserves.
  static bool is_identifier(const std::string& name);

  // At most about 60 characters of `text` around byte `at`, printable
  // (printable.h) and on one line (a line break as \n), with "..." where it
  // was cut: what a message quotes.
  static std::string excerpt(std::string_view text, std::size_t at = 0);

  // An expression in which calls of some functions of one argument are
  // computed by the caller, not by the expression: the log reader's mean(),
  // std() and rms() over the rows of a filter step, as in "log(std(az))".
  struct Call {
    std::string function;
    std::string argument;  // the text between its parentheses, as written
  };
  struct WithCalls {
    std::vector<Call> calls;  // in order of appearance
    // The names used outside every call (none is a valid aggregate for the
    // log reader, which says so).
    std::vector<std::string> names_outside;
    // The text with each call replaced by a variable: variables() are one
    // per call, in the order of `calls`, then names_outside.
    std::unique_ptr<Expression> outer;
  };
  // Cuts the calls of `functions` out of `text`. The text outside the calls
  // is checked as above (`functions` counting as functions of the
  // language); each argument only for balanced parentheses and printable
  // characters: the caller reads it (a column's exact name, or an
  // Expression). A call inside another's argument is an error. Throws
  // ExpressionError.
  static WithCalls cut_calls(const std::string& text, const std::vector<std::string>& functions);

 private:
  struct Checked;
  // `origin`: per character of `parsed`, the character of `shown` it comes from.
  Expression(const std::string& shown, const std::string& parsed, const std::vector<std::size_t>& origin,
             std::vector<std::string> variables);

  std::string text_;
  std::vector<std::string> variables_;
  std::unique_ptr<mu::Parser> parser_;
  // muparser reads variables through pointers; a stable store.
  std::unique_ptr<double[]> slots_;
};

}  // namespace skidimm

#endif  // SKIDIMM_CONFIG_EXPRESSION_H_
