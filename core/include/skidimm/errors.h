// Typed errors for everything a user can get wrong: bank files, plugins, logs.
//
// Each carries the place it refers to (file and line, or plugin path) so that
// a message alone tells the user where to look. Per-step numerical trouble is
// not an exception: it is reported in the step's result (imm_estimate.h).
#ifndef SKIDIMM_ERRORS_H_
#define SKIDIMM_ERRORS_H_

#include <stdexcept>
#include <string>

#include "skidimm/printable.h"

namespace skidimm {

// Every message is made printable (printable.h) when it is built: messages
// quote file contents, which may hold control characters, escape sequences,
// invalid UTF-8 or NUL bytes.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(printable(message)) {}
};

// A bank file (YAML) is malformed or inconsistent.
// what() reads "<file>:<line>: <field>: <message>".
class ConfigError : public Error {
 public:
  ConfigError(const std::string& file, int line, const std::string& field, const std::string& message)
      : Error(format(file, line, field, message)), file_(file), line_(line), field_(field), message_(message) {}

  const std::string& file() const { return file_; }
  int line() const { return line_; }  // 1-based; 0 when unknown
  const std::string& field() const { return field_; }
  const std::string& message() const { return message_; }  // what() without its file, line and field

 private:
  static std::string format(const std::string& file, int line, const std::string& field, const std::string& message) {
    std::string out = file;
    if (line > 0) out += ":" + std::to_string(line);
    out += ": ";
    if (!field.empty()) out += field + ": ";
    return out + message;
  }
  std::string file_;
  int line_;
  std::string field_;
  std::string message_;
};

// A plugin could not be found, loaded or instantiated.
class PluginError : public Error {
 public:
  using Error::Error;
};

// A log (CSV) is malformed. what() reads "<file>:<line>: <message>".
class LogError : public Error {
 public:
  LogError(const std::string& file, long line, const std::string& message)
      : Error(file + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + message),
        file_(file),
        line_(line) {}

  const std::string& file() const { return file_; }
  long line() const { return line_; }

 private:
  std::string file_;
  long line_;
};

}  // namespace skidimm

#endif  // SKIDIMM_ERRORS_H_
