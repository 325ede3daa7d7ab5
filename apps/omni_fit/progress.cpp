#include "progress.hpp"

#include <unistd.h>

#include <cstdio>

namespace omni_fit {

bool ProgressLine::stderr_wanted(bool quiet) { return !quiet && isatty(fileno(stderr)) != 0; }

void ProgressLine::update(std::string_view stage, std::size_t done, std::size_t total) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const bool new_stage = stage != stage_;
  if (!new_stage && done != total && now - last_draw_ < std::chrono::milliseconds(100)) return;
  if (new_stage) stage_.assign(stage);
  last_draw_ = now;
  // \r and a pad of spaces rather than an ANSI erase: works on any terminal.
  std::fprintf(stderr, "\romni_fit: %-28s %zu/%zu%-12s", stage_.c_str(), done, total, "");
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressLine::clear() {
  if (!enabled_ || !drawn_) return;
  std::fprintf(stderr, "\r%-72s\r", "");
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace omni_fit
