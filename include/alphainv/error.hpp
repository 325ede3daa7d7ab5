#pragma once
/// \file error.hpp
/// The one exception type of alphainv. Set-up and I/O throw it; real-time calls never do.

#include <stdexcept>
#include <string>
#include <utility>

namespace alphainv {

/// An error with context: which file, line and field, and what was expected versus found.
/// `what()` returns one readable line, e.g.
///   "runs/a.csv:12: column 'theta': expected a finite number, found 'nan'".
class Error : public std::runtime_error {
 public:
  /// \param message what is wrong (expected vs actual)
  /// \param file    the file concerned, or empty
  /// \param line    1-based line number, or 0 when not applicable
  /// \param field   the column, key or parameter concerned, or empty
  explicit Error(std::string message, std::string file = {}, long line = 0, std::string field = {})
      : std::runtime_error(Format(message, file, line, field)),
        message_(std::move(message)),
        file_(std::move(file)),
        line_(line),
        field_(std::move(field)) {}

  const std::string& message() const noexcept { return message_; }
  const std::string& file() const noexcept { return file_; }
  long line() const noexcept { return line_; }
  const std::string& field() const noexcept { return field_; }

 private:
  static std::string Format(const std::string& message, const std::string& file, long line,
                            const std::string& field) {
    std::string out;
    if (!file.empty()) {
      out += file;
      if (line > 0) out += ":" + std::to_string(line);
      out += ": ";
    } else if (line > 0) {
      out += "line " + std::to_string(line) + ": ";
    }
    if (!field.empty()) out += "'" + field + "': ";
    out += message;
    return out;
  }

  std::string message_;
  std::string file_;
  long line_ = 0;
  std::string field_;
};

}  // namespace alphainv
