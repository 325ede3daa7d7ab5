#pragma once
/// \file progress.hpp
/// A one-line progress display on stderr for `omni_fit fit`: "omni_fit: <stage> n/N", redrawn in
/// place. Draws only when enabled (stderr is a terminal and not --quiet); otherwise every call is
/// a no-op, so piped output stays clean.

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>

namespace omni_fit {

class ProgressLine {
 public:
  /// enabled: draw at all (use ProgressLine::for_stderr(quiet) for the usual rule).
  explicit ProgressLine(bool enabled) : enabled_(enabled) {}
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;
  ~ProgressLine() { clear(); }

  /// Enabled when stderr is a terminal (isatty) and not `quiet`.
  static bool stderr_wanted(bool quiet);

  /// Shows `stage done/total`. Redraws at most every 100 ms within a stage, and always on a new
  /// stage or when done == total. Not thread-safe: callers serialise (fit_dataset does).
  void update(std::string_view stage, std::size_t done, std::size_t total);

  /// Erases the line (before normal output is printed).
  void clear();

  bool enabled() const { return enabled_; }

 private:
  bool enabled_;
  bool drawn_ = false;
  std::string stage_;
  std::chrono::steady_clock::time_point last_draw_{};
};

}  // namespace omni_fit
