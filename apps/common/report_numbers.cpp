#include "apps/common/report_numbers.hpp"

#include <cmath>
#include <cstdio>

namespace alphainv::apps {

std::string table_cell(double x, const char* printf_format) {
  if (std::isnan(x)) return "–";
  if (std::isinf(x)) return x > 0 ? "∞" : "−∞";
  char b[64];
  std::snprintf(b, sizeof b, printf_format, x);
  return b;
}

nlohmann::json json_number(double x) {
  return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
}

}  // namespace alphainv::apps
