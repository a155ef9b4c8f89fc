// Expression: an arithmetic expression of named values, such as a bank's
// `columns: {inputs: {abs_dv: "abs(velR - velL)"}}`.
//
// Parsing and evaluation are muparser's (Debian libmuparser-dev): the usual
// operators (+ - * / ^, comparisons, ?:), abs, sign, sqrt, exp, log (natural),
// log10, sin, cos, atan2-free trigonometry, min, max, and numbers. Every other
// identifier is a variable; variables() lists them in order of first use, and
// evaluate() takes their values in that order. Nothing is evaluated while
// parsing, so an expression is checked before any data is read.
//
// One Expression is used from one thread at a time (muparser keeps a stack).
#ifndef SKIDIMM_EXPRESSION_H_
#define SKIDIMM_EXPRESSION_H_

#include <memory>
#include <stdexcept>
#include <string>
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
  // Parses `text`. Throws ExpressionError.
  explicit Expression(const std::string& text);
  ~Expression();
  Expression(Expression&&) noexcept;
  Expression& operator=(Expression&&) noexcept;
  Expression(const Expression&) = delete;
  Expression& operator=(const Expression&) = delete;

  const std::string& text() const { return text_; }
  const std::vector<std::string>& variables() const { return variables_; }

  // The value for variables()[i] = values[i]. NaN or inf when the arithmetic
  // gives them (log(0), 0/0); never throws.
  double evaluate(const double* values) const;

  // True if `name` could be a variable in an expression (letters, digits and
  // '_', not starting with a digit). Other column names can only be used
  // whole, as a plain column.
  static bool is_identifier(const std::string& name);

 private:
  std::string text_;
  std::vector<std::string> variables_;
  std::unique_ptr<mu::Parser> parser_;
  // muparser reads variables through pointers; a deque-like stable store.
  std::unique_ptr<double[]> slots_;
};

}  // namespace skidimm

#endif  // SKIDIMM_EXPRESSION_H_
