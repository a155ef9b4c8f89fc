#include "skidimm/config/expression.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace skidimm {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::Not;

// The error's message, or "" (and a test failure) when `text` parses.
std::string error_of(const std::string& text) {
  try {
    Expression e(text);
    ADD_FAILURE() << "\"" << text << "\" parsed, with " << e.variables().size() << " variable(s)";
  } catch (const ExpressionError& e) {
    return e.what();
  }
  return "";
}

double value_of(const std::string& text, const std::vector<double>& values) {
  const Expression e(text);
  EXPECT_EQ(e.variables().size(), values.size()) << text;
  return e.evaluate(values.data());
}

TEST(Expression, EvaluatesTheDocumentedLanguage) {
  EXPECT_EQ(value_of("abs(a - b) / 2", {1.0, 4.0}), 1.5);
  EXPECT_EQ(value_of("a ^ 2 + -b", {3.0, 1.0}), 8.0);
  EXPECT_EQ(value_of("a > 1 && b <= 2 || a == 7", {2.0, 2.0}), 1.0);
  EXPECT_EQ(value_of("a != 1 ? a : 10", {1.0}), 10.0);
  EXPECT_EQ(value_of("min(a, 2, b) + max(a)", {3.0, -1.0}), 2.0);
  EXPECT_NEAR(value_of("log(a) + log10(b) + exp(0) + sqrt(4) + sign(-a) + sin(0) + cos(0)", {std::exp(1.0), 100.0}),
              1.0 + 2.0 + 1.0 + 2.0 - 1.0 + 0.0 + 1.0, 1e-15);
  EXPECT_EQ(value_of(".5 * 1e-3 + 2.", {}), 2.0005);
  EXPECT_TRUE(std::isinf(value_of("1 / a", {0.0})));
}

TEST(Expression, VariablesAreListedInOrderOfFirstUse) {
  EXPECT_THAT(Expression("zeta + alpha * zeta - beta").variables(), ElementsAre("zeta", "alpha", "beta"));
  const Expression e("b - a");
  const double values[] = {10.0, 4.0};  // b, a
  EXPECT_EQ(e.evaluate(values), 6.0);
}

// muparser's own language is larger: none of it may be reached.
TEST(Expression, AssignmentListsAndNulAreRefused) {
  EXPECT_THAT(error_of("phi_dot_L = 3"), HasSubstr("assignment ('=') is not part of the language"));
  EXPECT_THAT(error_of("phi_dot_L += 3"), HasSubstr("assignment ('+=')"));
  EXPECT_THAT(error_of("phi_dot_L, phi_dot_R"), HasSubstr("a ',' outside the arguments of min() or max()"));
  EXPECT_THAT(error_of("(a, b)"), HasSubstr("a ',' outside the arguments"));
  EXPECT_THAT(error_of("abs(a, b)"), HasSubstr("a ',' in a function of one argument"));
  EXPECT_THAT(error_of("min((a, b))"), HasSubstr("a ',' outside the arguments"));
  EXPECT_THAT(error_of(std::string("phi_dot_L\0+1", 12)), HasSubstr("a control character (byte 0) at character 10"));
  EXPECT_THAT(error_of("a\n+ b"), HasSubstr("cannot parse \"a\\n+ b\": a control character (byte 10)"));
}

TEST(Expression, OnlyTheDocumentedFunctionsAndNoInternalOrReservedNames) {
  EXPECT_THAT(error_of("mean(a)"), HasSubstr("mean() aggregates the rows of a filter step"));
  for (const char* text : {"sum(a, b)", "avg(a)", "rint(a)", "tan(a)", "ln(a)", "_skidimm_step0(a)"}) {
    const std::string message = error_of(text);
    if (text[0] == '_') {
      EXPECT_THAT(message, HasSubstr("names starting with '_' are reserved")) << text;
    } else {
      EXPECT_THAT(message, HasSubstr("unknown function")) << text;
      EXPECT_THAT(message, HasSubstr("abs, sign, sqrt, exp, log, log10, sin, cos, min, max")) << text;
    }
  }
  EXPECT_THAT(error_of("a * _pi"), HasSubstr("'_pi': names starting with '_' are reserved"));
  EXPECT_THAT(error_of("_e"), HasSubstr("reserved"));
  EXPECT_THAT(error_of("abs(V) + _skidimm_step99"), HasSubstr("'_skidimm_step99': names starting with '_'"));
  EXPECT_THAT(error_of("abs + 1"), HasSubstr("'abs' is a function: call it as abs(...)"));
}

TEST(Expression, OtherCharactersAndMalformedNumbersAreRefused) {
  EXPECT_THAT(error_of("a # b"), HasSubstr("'#' is not part of the language at character 3"));
  EXPECT_THAT(error_of("\"a\""), HasSubstr("'\"' is not part of the language"));
  EXPECT_THAT(error_of("a; b"), HasSubstr("';' is not part of the language"));
  EXPECT_THAT(error_of("a & b"), HasSubstr("'&' is not part of the language"));
  EXPECT_THAT(error_of("!a"), HasSubstr("'!' is not part of the language"));
  EXPECT_THAT(error_of("vitesse_\xc3\xa9"), HasSubstr("a character outside ASCII"));
  EXPECT_THAT(error_of("2x"), HasSubstr("a number directly followed by 'x'"));
  EXPECT_THAT(error_of("0x1f"), HasSubstr("a number directly followed by 'x'"));
  EXPECT_THAT(error_of("1.2.3"), HasSubstr("a number directly followed by '.'"));
  EXPECT_THAT(error_of("a * 1e999"), HasSubstr("the number 1e999 is out of range"));
  EXPECT_THAT(error_of(""), HasSubstr("the expression is empty"));
  EXPECT_THAT(error_of(" \t "), HasSubstr("the expression is empty"));
  EXPECT_THAT(error_of("a +* b"), HasSubstr("Unexpected operator"));
  EXPECT_THAT(error_of("abs((V)"), HasSubstr("unbalanced parentheses: this '(' is not closed at character 4"));
  EXPECT_THAT(error_of("a)"), HasSubstr("a ')' without its '('"));
}

// Every error names the character of the user's text it is at, counted
// from 1: muparser's own (its position counts from 0, in a text where a
// call or a topic path stands replaced) are restated so.
TEST(Expression, EveryErrorCountsTheUsersCharactersFromOne) {
  EXPECT_THAT(error_of("a # b"), HasSubstr("'#' is not part of the language at character 3"));
  const std::string muparser = error_of("a +* b");
  EXPECT_THAT(muparser, HasSubstr("cannot parse \"a +* b\": Unexpected operator \"*\" found at character 4"));
  EXPECT_THAT(muparser, Not(HasSubstr("position")));
  EXPECT_THAT(error_of("a b"), HasSubstr("Unexpected variable \"b\" found at character 3"));
  EXPECT_THAT(error_of("min(a,,b)"), HasSubstr("Unexpected argument separator at character 7"));
  // Past the last character: the message says what is missing there.
  EXPECT_THAT(error_of("a >"), ::testing::EndsWith("cannot parse \"a >\": Unexpected end of expression"));
  // Where muparser's text differs from the user's.
  try {
    Expression::cut_calls("mean(wz) > > 1", {"mean"});
    ADD_FAILURE() << "parsed";
  } catch (const ExpressionError& e) {
    EXPECT_THAT(e.what(), HasSubstr("Unexpected operator \">\" found at character 12"));
  }
  EXPECT_THAT(error_of("/imu/data.angular_velocity.z * * 2"), HasSubstr("\"*\" found at character 32"));
}

TEST(Expression, LengthAndNestingAreBoundedAndMessagesQuoteAShortExcerpt) {
  const std::string huge = "a" + std::string(10'000'000, '+');
  const std::string message = error_of(huge);
  EXPECT_THAT(message, HasSubstr("10000001 characters long, more than an expression may have (1024)"));
  EXPECT_LT(message.size(), 200u);
  // Within the length, an error far into the text shows the text around it.
  const std::string long_text = std::string(500, ' ') + "a = 1" + std::string(500, ' ');
  const std::string near = error_of(long_text);
  EXPECT_THAT(near, HasSubstr("...")) << near;
  EXPECT_THAT(near, HasSubstr("a = 1")) << near;
  EXPECT_LT(near.size(), 200u) << near;
  std::string deep;
  for (int i = 0; i < 40; ++i) deep += "(";
  deep += "a";
  for (int i = 0; i < 40; ++i) deep += ")";
  EXPECT_THAT(error_of(deep), HasSubstr("parentheses nested more than 32 deep"));
  std::string ok;
  for (int i = 0; i < 32; ++i) ok += "abs(";
  ok += "a";
  for (int i = 0; i < 32; ++i) ok += ")";
  EXPECT_EQ(value_of(ok, {-2.0}), 2.0);
  // Control bytes in an excerpt are escaped.
  EXPECT_THAT(error_of("a \x1b[2J"), HasSubstr("\\x1B"));
}

TEST(Expression, CutCallsLeavesTheCallsToTheCaller) {
  const Expression::WithCalls cut = Expression::cut_calls("log(std(az)) + 2 * mean (header.stamp)", {"mean", "std"});
  ASSERT_EQ(cut.calls.size(), 2u);
  EXPECT_EQ(cut.calls[0].function, "std");
  EXPECT_EQ(cut.calls[0].argument, "az");
  EXPECT_EQ(cut.calls[1].function, "mean");
  EXPECT_EQ(cut.calls[1].argument, "header.stamp") << "an argument may be a column used whole";
  EXPECT_TRUE(cut.names_outside.empty());
  ASSERT_EQ(cut.outer->variables().size(), 2u);
  const double values[] = {std::exp(2.0), 5.0};
  EXPECT_NEAR(cut.outer->evaluate(values), 12.0, 1e-14);

  const Expression::WithCalls mixed = Expression::cut_calls("mean(wz) + cur", {"mean"});
  EXPECT_THAT(mixed.names_outside, ElementsAre("cur"));
  EXPECT_EQ(mixed.outer->variables().size(), 2u);
  EXPECT_TRUE(Expression::cut_calls("a + b", {"mean"}).calls.empty());

  auto cut_error = [](const std::string& text) {
    try {
      Expression::cut_calls(text, {"mean", "std"});
    } catch (const ExpressionError& e) {
      return std::string(e.what());
    }
    ADD_FAILURE() << text;
    return std::string();
  };
  EXPECT_THAT(cut_error("mean(std(wz))"), HasSubstr("std() inside mean()"));
  EXPECT_THAT(cut_error("mean((wz)"), HasSubstr("unbalanced parentheses: the '(' of mean( is not closed"));
  EXPECT_THAT(cut_error(std::string("mean(w\0z)", 9)), HasSubstr("a control character (byte 0)"));
  EXPECT_THAT(cut_error("mean(wz) + _call0"), HasSubstr("names starting with '_' are reserved"));
  EXPECT_THAT(cut_error("mean(wz), 1"), HasSubstr("a ',' outside"));
  EXPECT_THAT(cut_error("mean + 1"), HasSubstr("'mean' is a function"));
}

}  // namespace
}  // namespace skidimm
