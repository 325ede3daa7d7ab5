#pragma once
// Internal (not API): the checks that validate() functions use to name a bad field.

#include <cmath>
#include <cstdio>
#include <string>

#include "alphainv/error.hpp"

namespace alphainv::detail {

inline std::string num(double x) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

[[noreturn]] inline void bad(const std::string& field, const std::string& expected, double got) {
  throw Error("expected " + expected + ", got " + num(got), {}, 0, field);
}

inline void require_finite(const std::string& field, double x) {
  if (!std::isfinite(x)) bad(field, "a finite number", x);
}

inline void require_nonnegative(const std::string& field, double x) {
  if (!std::isfinite(x) || x < 0.0) bad(field, "a finite number >= 0", x);
}

inline void require_positive(const std::string& field, double x) {
  if (!std::isfinite(x) || !(x > 0.0)) bad(field, "a finite number > 0", x);
}

}  // namespace alphainv::detail
