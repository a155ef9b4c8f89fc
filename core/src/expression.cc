#include "skidimm/config/expression.h"

#include <muParser.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "skidimm/printable.h"
#include "topic_path_names.h"

namespace skidimm {

namespace {

// The functions of the language; `many`: one or more arguments separated by ','.
struct Function {
  const char* name;
  bool many;
};
constexpr Function kFunctions[] = {{"abs", false},   {"sign", false}, {"sqrt", false}, {"exp", false}, {"log", false},
                                   {"log10", false}, {"sin", false},  {"cos", false},  {"min", true},  {"max", true}};

// The name the expression given to muparser gives to the value of call i
// (cut_calls): it starts with '_', which no name of the language may.
std::string call_variable(std::size_t i) { return "_call" + std::to_string(i); }

bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
bool is_name_char(char c) { return is_letter(c) || is_digit(c) || c == '_'; }

std::string function_list() {
  std::string out;
  for (const Function& f : kFunctions) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

const Function* find_function(std::string_view name) {
  for (const Function& f : kFunctions) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

[[noreturn]] void fail(const std::string& text, std::size_t at, const std::string& what) {
  throw ExpressionError("cannot parse \"" + Expression::excerpt(text, at) + "\": " + what + " at character " +
                        std::to_string(at + 1));
}

// The end of the number starting at text[i]: digits, an optional fraction,
// an optional exponent.
std::size_t number_end(const std::string& text, std::size_t i) {
  while (i < text.size() && is_digit(text[i])) ++i;
  if (i < text.size() && text[i] == '.') {
    ++i;
    while (i < text.size() && is_digit(text[i])) ++i;
  }
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    std::size_t j = i + 1;
    if (j < text.size() && (text[j] == '+' || text[j] == '-')) ++j;
    if (j < text.size() && is_digit(text[j])) {
      i = j;
      while (i < text.size() && is_digit(text[i])) ++i;
    }
  }
  return i;
}

// The text between the '(' at `open` and its ')', checked for printable
// characters only: the argument of a call the caller computes.
std::size_t matching_parenthesis(const std::string& text, std::size_t open, const std::string& function) {
  int depth = 0;
  for (std::size_t i = open; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) fail(text, i, "a control character (byte " + std::to_string(c) + ")");
    if (c == '(') ++depth;
    if (c == ')' && --depth == 0) return i;
  }
  fail(text, open, "unbalanced parentheses: the '(' of " + function + "( is not closed");
}

// muparser's message about `shown`, its position (0-based, in the text
// muparser was given, which differs from the user's where calls or topic
// paths were replaced) restated as the language's own errors state theirs:
// the user's character, counted from 1.
std::string muparser_error(const std::string& shown, const std::vector<std::size_t>& origin, std::string message,
                           int position) {
  if (!message.empty() && message.back() == '.') message.pop_back();
  std::size_t at = 0;
  std::string where;
  if (position >= 0) {
    const std::string number = std::to_string(position);
    for (const std::string& phrase :
         {" at expression position " + number, " at position " + number, " (position: " + number + ")"}) {
      const std::size_t found = message.find(phrase);
      if (found == std::string::npos) continue;
      message.erase(found, phrase.size());
      break;
    }
    // Past the last character muparser has only its own end, and the
    // message says what is missing there.
    const auto p = static_cast<std::size_t>(position);
    if (p < origin.size()) {
      at = origin[p];
      where = " at character " + std::to_string(at + 1);
    } else {
      at = shown.size();
      if (message.find("end of expression") == std::string::npos) where = " at the end";
    }
  }
  // muparser's message quotes a token, which may be long.
  if (message.size() > 120) message = message.substr(0, 120) + "...";
  return "cannot parse \"" + Expression::excerpt(shown, at) + "\": " + printable(message) + where;
}

}  // namespace

// The token-by-token check of the language (see the header). It also
// collects the names, in order of first use, and, for cut_calls, cuts out
// the calls of `callers`, leaving a variable for each in `parsed`.
struct Expression::Checked {
  std::string parsed;  // what muparser is given
  // Per character of `parsed`, where in the text it comes from: the
  // character itself, or the start of what it stands for (a topic path, a
  // call cut out), so that muparser's positions name the user's characters.
  std::vector<std::size_t> origin;
  std::vector<std::string> names;
  std::vector<Call> calls;

  Checked(const std::string& text, const std::vector<std::string>& callers) : text_(text), callers_(callers) {
    if (text.size() > kMaxLength) {
      throw ExpressionError("cannot parse \"" + excerpt(text) + "\": " + std::to_string(text.size()) +
                            " characters long, more than an expression may have (" + std::to_string(kMaxLength) + ")");
    }
    bool any_token = false;
    while (i_ < text_.size()) {
      const char c = text_[i_];
      if (c == ' ' || c == '\t') {
        emit(" ", i_);
        ++i_;
        continue;
      }
      any_token = true;
      if (c == '/' && operand_expected() && topic_path_names::path_end(text_, i_) > i_) {
        topic_path();
      } else if (is_letter(c) || c == '_') {
        name();
      } else if (is_digit(c) || (c == '.' && i_ + 1 < text_.size() && is_digit(text_[i_ + 1]))) {
        number();
      } else {
        symbol();
      }
    }
    if (!any_token) throw ExpressionError("cannot parse \"" + excerpt(text) + "\": the expression is empty");
    if (!open_.empty()) fail(text_, open_.back().second, "unbalanced parentheses: this '(' is not closed");
  }

 private:
  // What an open '(' belongs to.
  enum class Frame { kGroup, kOneArgument, kManyArguments };

  // Whether the next token must be an operand: nothing yet, or an operator,
  // '(' or ',' last. A '/' there starts a topic path, never a division.
  bool operand_expected() const {
    const std::size_t last = parsed.find_last_not_of(' ');
    if (last == std::string::npos) return true;
    const char c = parsed[last];
    return !(is_name_char(c) || c == ')' || c == '.');
  }

  // A bag's topic path (topic_path_names.h): one variable, named as itself,
  // given to muparser as a name no name of the language can be.
  void topic_path() {
    const std::size_t end = topic_path_names::path_end(text_, i_);
    const std::string path = text_.substr(i_, end - i_);
    if (std::find(paths_.begin(), paths_.end(), path) == paths_.end()) paths_.push_back(path);
    if (std::find(names.begin(), names.end(), path) == names.end()) names.push_back(path);
    const auto k = static_cast<std::size_t>(std::find(paths_.begin(), paths_.end(), path) - paths_.begin());
    emit(topic_path_names::parser_name(k), i_);
    i_ = end;
  }

  // A name: a variable, a function of the language, or a call of a caller.
  void name() {
    std::size_t end = i_;
    while (end < text_.size() && is_name_char(text_[end])) ++end;
    const std::string name = text_.substr(i_, end - i_);
    if (name[0] == '_') {
      fail(text_, i_,
           "'" + excerpt(name) +
               "': names starting with '_' are reserved (a column of that name can only be used whole, as the "
               "column itself)");
    }
    std::size_t next = end;
    while (next < text_.size() && (text_[next] == ' ' || text_[next] == '\t')) ++next;
    const bool called = next < text_.size() && text_[next] == '(';
    const bool caller = std::find(callers_.begin(), callers_.end(), name) != callers_.end();
    const Function* function = find_function(name);
    if (!called) {
      if (function != nullptr || caller) {
        fail(text_, i_,
             "'" + name + "' is a function: call it as " + name +
                 "(...) (a column of that name can only be used whole, as the column itself)");
      }
      if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
      copy(end);
      return;
    }
    if (caller) {
      cut_call(name, next);
      return;
    }
    if (function == nullptr && (name == "mean" || name == "std" || name == "rms" || name == "diff_std")) {
      fail(text_, i_,
           name +
               "() aggregates the rows of a filter step: it is for a bank's measurements only (with "
               "sampling.rate)");
    }
    if (function == nullptr) {
      // The aggregates too, where they may be called: a misspelt mean() is a
      // misspelt aggregate, not one of the row functions.
      std::string aggregates;
      for (const std::string& c : callers_) aggregates += (aggregates.empty() ? "" : ", ") + c;
      fail(text_, i_,
           "unknown function '" + excerpt(name) + "' (the functions are " + function_list() +
               (aggregates.empty() ? std::string() : "; over a step's rows, " + aggregates) + ")");
    }
    open(function->many ? Frame::kManyArguments : Frame::kOneArgument, next);
    copy(next + 1);
  }

  // The call of a caller whose '(' is at `open`: its argument is the
  // caller's to read, and may not hold another such call.
  void cut_call(const std::string& function, std::size_t open) {
    const std::size_t close = matching_parenthesis(text_, open, function);
    const std::string argument = text_.substr(open + 1, close - open - 1);
    for (const std::string& other : callers_) {
      for (std::size_t at = argument.find(other); at != std::string::npos; at = argument.find(other, at + 1)) {
        std::size_t after = at + other.size();
        while (after < argument.size() && (argument[after] == ' ' || argument[after] == '\t')) ++after;
        if ((at == 0 || !is_name_char(argument[at - 1])) && after < argument.size() && argument[after] == '(') {
          fail(text_, open + 1 + at, other + "() inside " + function + "(): a call of one cannot contain another");
        }
      }
    }
    calls.push_back(Call{function, argument});
    emit(call_variable(calls.size() - 1), i_);
    i_ = close + 1;
  }

  void number() {
    const std::size_t end = number_end(text_, i_);
    if (end < text_.size() && (is_name_char(text_[end]) || text_[end] == '.')) {
      fail(text_, end, "a number directly followed by '" + excerpt(text_.substr(end, 1)) + "'");
    }
    double value = 0.0;
    const auto read = std::from_chars(text_.data() + i_, text_.data() + end, value);
    if (read.ec != std::errc() || !std::isfinite(value)) {
      fail(text_, i_, "the number " + excerpt(text_.substr(i_, end - i_)) + " is out of range");
    }
    copy(end);
  }

  // An operator, a parenthesis or a ','; '=' only inside ==, <=, >=, !=, and
  // '&', '|' only doubled.
  void symbol() {
    const char c = text_[i_];
    const char next = i_ + 1 < text_.size() ? text_[i_ + 1] : '\0';
    std::size_t length = 0;
    switch (c) {
      case '+':
      case '-':
      case '*':
      case '/':
      case '^':
      case '?':
      case ':':
        length = next == '=' ? 0 : 1;
        break;
      case '<':
      case '>':
        length = next == '=' ? 2 : 1;
        break;
      case '=':
      case '!':
        length = next == '=' ? 2 : 0;
        break;
      case '&':
      case '|':
        length = next == c ? 2 : 0;
        break;
      case '(':
        open(Frame::kGroup, i_);
        length = 1;
        break;
      case ')':
        if (open_.empty()) fail(text_, i_, "a ')' without its '('");
        open_.pop_back();
        length = 1;
        break;
      case ',':
        if (open_.empty() || open_.back().first == Frame::kGroup) {
          fail(text_, i_, "a ',' outside the arguments of min() or max() (an expression is one value, not a list)");
        }
        if (open_.back().first == Frame::kOneArgument) fail(text_, i_, "a ',' in a function of one argument");
        length = 1;
        break;
      default:
        break;
    }
    if (length == 0) refuse_symbol(c, next);
    copy(i_ + length);
  }

  [[noreturn]] void refuse_symbol(char c, char next) const {
    const unsigned char byte = static_cast<unsigned char>(c);
    if (c == '=' || next == '=') {
      fail(text_, i_,
           "assignment ('" + excerpt(text_.substr(i_, next == '=' ? 2 : 1)) +
               "') is not part of the language (a comparison is ==)");
    }
    if (byte < 0x20 || byte == 0x7f) fail(text_, i_, "a control character (byte " + std::to_string(byte) + ")");
    if (byte >= 0x80) fail(text_, i_, "a character outside ASCII (a column whose name has one can only be used whole)");
    fail(text_, i_, "'" + std::string(1, c) + "' is not part of the language");
  }

  // Appends `replacement` for the text starting at `from`.
  void emit(const std::string& replacement, std::size_t from) {
    parsed += replacement;
    origin.insert(origin.end(), replacement.size(), from);
  }

  // Appends the text from i_ to `end` as it is, and moves on to `end`.
  void copy(std::size_t end) {
    parsed += text_.substr(i_, end - i_);
    for (; i_ < end; ++i_) origin.push_back(i_);
  }

  void open(Frame frame, std::size_t at) {
    open_.emplace_back(frame, at);
    if (static_cast<int>(open_.size()) > kMaxDepth) {
      fail(text_, at, "parentheses nested more than " + std::to_string(kMaxDepth) + " deep");
    }
  }

  const std::string& text_;
  const std::vector<std::string>& callers_;
  std::size_t i_ = 0;
  std::vector<std::pair<Frame, std::size_t>> open_;  // what each open '(' is, and where
  std::vector<std::string> paths_;                   // topic paths, in order of first use
};

Expression::Expression(const std::string& text)
    : Expression([&] {
        Checked checked(text, {});
        return Expression(text, checked.parsed, checked.origin, std::move(checked.names));
      }()) {}

Expression::Expression(const std::string& shown, const std::string& parsed, const std::vector<std::size_t>& origin,
                       std::vector<std::string> variables)
    : text_(shown), variables_(std::move(variables)), parser_(std::make_unique<mu::Parser>()) {
  try {
    // Only what the language has: muparser's constants (_pi, _e) go, and
    // its variables are exactly the names found above (an undefined name is
    // an error, never a new variable).
    parser_->ClearConst();
    slots_ = std::make_unique<double[]>(variables_.size() + 1);
    std::size_t paths = 0;  // topic paths are named for muparser in order of first use, as Checked did
    for (std::size_t i = 0; i < variables_.size(); ++i) {
      slots_[i] = 0.0;
      const std::string& name = variables_[i];
      parser_->DefineVar(topic_path_names::is_path(name) ? topic_path_names::parser_name(paths++) : name, &slots_[i]);
    }
    parser_->SetExpr(parsed);
    parser_->Eval();  // compiles to bytecode now, so evaluate() never meets a parse error
  } catch (const mu::Parser::exception_type& e) {
    throw ExpressionError(muparser_error(shown, origin, e.GetMsg(), e.GetPos()));
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
  if (name.empty() || is_digit(name[0])) return false;
  return std::all_of(name.begin(), name.end(), is_name_char);
}

namespace {

// printable() keeps line breaks; a quoted excerpt stays on its line.
std::string one_line(std::string_view text) {
  std::string out;
  for (char c : printable(text)) out += c == '\n' ? std::string("\\n") : std::string(1, c);
  return out;
}

}  // namespace

std::string Expression::excerpt(std::string_view text, std::size_t at) {
  constexpr std::size_t kShown = 60;
  if (text.size() <= kShown) return one_line(text);
  const std::size_t begin = at > kShown / 2 ? std::min(at - kShown / 2, text.size() - kShown) : 0;
  return (begin > 0 ? "..." : "") + one_line(text.substr(begin, kShown)) + (begin + kShown < text.size() ? "..." : "");
}

Expression::WithCalls Expression::cut_calls(const std::string& text, const std::vector<std::string>& functions) {
  Checked checked(text, functions);
  WithCalls out;
  out.calls = std::move(checked.calls);
  out.names_outside = checked.names;
  std::vector<std::string> variables;
  for (std::size_t i = 0; i < out.calls.size(); ++i) variables.push_back(call_variable(i));
  variables.insert(variables.end(), checked.names.begin(), checked.names.end());
  out.outer.reset(new Expression(text, checked.parsed, checked.origin, std::move(variables)));
  return out;
}

}  // namespace skidimm
