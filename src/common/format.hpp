#pragma once
/// \file format.hpp
/// Private plumbing (src/common, not installed): the numbers of alphainv's messages, notes,
/// reports and files, one formatter for each style the code uses. Non-finite values print as
/// printf and std::to_chars print them ("nan", "inf", "-inf"), so an error message shows what
/// was found; a report table that wants a dash instead says so itself. Not real-time safe.

#include <array>
#include <charconv>
#include <cstdarg>
#include <cstdio>
#include <string>

#include "alphainv/model/detail/field_checks.hpp"  // detail::num, the core's "%.6g"

namespace alphainv::common {

/// printf into a std::string; the compiler checks `printf_format` against the arguments.
/// format("pose %zu: got %g", 3, 0.5) == "pose 3: got 0.5".
[[gnu::format(printf, 1, 2)]] inline std::string format(const char* printf_format, ...) {
  std::array<char, 128> buf{};
  va_list args;
  va_start(args, printf_format);
  va_list again;
  va_copy(again, args);
  const int n = std::vsnprintf(buf.data(), buf.size(), printf_format, args);
  va_end(args);
  std::string out;
  if (n > 0 && static_cast<std::size_t>(n) < buf.size()) {
    out.assign(buf.data(), static_cast<std::size_t>(n));
  } else if (n > 0) {
    out.resize(static_cast<std::size_t>(n) + 1);
    std::vsnprintf(out.data(), out.size(), printf_format, again);
    out.resize(static_cast<std::size_t>(n));
  }
  va_end(again);
  return out;
}

/// x with 6 significant digits ("%.6g", the same as "%g"): "0.1", "1.23457e+06", "nan". The
/// core's formatter of validate() messages, so messages of every component read alike.
using alphainv::detail::num;

/// x with `digits` significant digits ("%.*g"): sig(3.14159, 3) == "3.14", sig(2e-7, 2) == "2e-07".
inline std::string sig(double x, int digits) { return format("%.*g", digits, x); }

/// x with `decimals` digits after the point ("%.*f"): fixed(2.5, 2) == "2.50".
inline std::string fixed(double x, int decimals) { return format("%.*f", decimals, x); }

/// Appends the shortest text that reads back as exactly `x` (std::to_chars): "0.1", "1e+300",
/// "5e-324". For files that must round-trip bit for bit (the dataset CSV, plan JSON).
inline void append_shortest(std::string& out, double x) {
  std::array<char, 32> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), x);
  out.append(buf.data(), res.ptr);
}

/// The shortest text that reads back as exactly `x` (see append_shortest()).
inline std::string shortest(double x) {
  std::string out;
  append_shortest(out, x);
  return out;
}

}  // namespace alphainv::common
