#pragma once
/// Errors. Bad input is normal: the library throws a formfactor::Error (or a subclass) that
/// carries where the problem is; the CLI prints `what()` as one line and exits non-zero.

#include <stdexcept>
#include <string>

namespace formfactor {

/// Base of every error the library reports on purpose.
class Error : public std::runtime_error {
  public:
    explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// Bad input in a file: `what()` is "FILE:LINE: message" (or "FILE: message" when line is 0).
class InputError : public Error {
  public:
    InputError(std::string file, int line, const std::string& message)
        : Error(format(file, line, message)),
          file_(std::move(file)),
          line_(line),
          message_(message) {}
    const std::string& file() const { return file_; }
    int line() const { return line_; }
    /// The message without the location.
    const std::string& message() const { return message_; }

  private:
    static std::string format(const std::string& file, int line, const std::string& message) {
        if (line > 0) return file + ":" + std::to_string(line) + ": " + message;
        return file + ": " + message;
    }
    std::string file_;
    int line_ = 0;
    std::string message_;
};

/// A bad option value or combination: `what()` is "field: message". The library names the
/// option's field (e.g. "tolerance", "samples", "rows"); the CLI maps fields to its flags
/// (cli_flag()) and may throw with a flag itself ("--out-dir"). A message or warning of the
/// library that names an option in its text quotes the field in backquotes ("raise
/// `max_iterations`"): the CLI shows those as its flags too, Python users as they are.
class OptionError : public Error {
  public:
    OptionError(std::string field, const std::string& message)
        : Error(field + ": " + message), field_(std::move(field)), message_(message) {}
    /// The option field (or, from the CLI, the flag).
    const std::string& field() const { return field_; }
    const std::string& option() const { return field_; }
    /// The message without the field.
    const std::string& message() const { return message_; }

  private:
    std::string field_;
    std::string message_;
};

/// Geometry the library cannot handle (degenerate, non-planar, ...), found outside a file
/// (built-in scenes, API callers).
class GeometryError : public Error {
  public:
    using Error::Error;
};

/// A run that needs more of the machine than it has (memory), found before it starts: the
/// message says what is needed, what is available and what to do instead.
class ResourceError : public Error {
  public:
    using Error::Error;
};

[[noreturn]] void assertion_failed(const char* expr, const char* file, int line);

}  // namespace formfactor

/// Always-on invariant check: a failure is a bug in formfactor, not bad input.
#define FF_ASSERT(expr) \
    ((expr) ? static_cast<void>(0) : ::formfactor::assertion_failed(#expr, __FILE__, __LINE__))
