#include "apps/common/units.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <optional>

namespace alphainv::apps {

namespace {

std::string trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return std::string(s);
}

/// The whole of `text` as a finite number, or nullopt.
std::optional<double> to_number(const std::string& text) {
  if (text.empty()) return std::nullopt;
  errno = 0;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(x))
    return std::nullopt;
  return x;
}

/// Splits "500ms" into "500" and "ms" (the unit: the trailing letters).
std::pair<std::string, std::string> number_and_unit(std::string_view text) {
  const std::string s = trim(text);
  std::size_t k = s.size();
  while (k > 0 && std::isalpha(static_cast<unsigned char>(s[k - 1]))) --k;
  return {trim(s.substr(0, k)), s.substr(k)};
}

}  // namespace

double parse_frequency_hz(std::string_view text, const std::string& field) {
  const auto [number, unit] = number_and_unit(text);
  const std::optional<double> x = to_number(number);
  double scale = 0.0;
  if (unit.empty() || unit == "Hz" || unit == "hz") scale = 1.0;
  if (unit == "kHz" || unit == "khz") scale = 1e3;
  if (!x || scale == 0.0) {
    throw Error("expected a frequency like 3Hz, 0.25Hz or 1kHz, got \"" + std::string(text) + "\"",
                {}, 0, field);
  }
  if (!(*x > 0.0))
    throw Error("expected a frequency > 0 Hz, got \"" + std::string(text) + "\"", {}, 0, field);
  return *x * scale;
}

double parse_duration_s(std::string_view text, const std::string& field) {
  const auto [number, unit] = number_and_unit(text);
  const std::optional<double> x = to_number(number);
  double scale = 0.0;
  if (unit.empty() || unit == "s") scale = 1.0;
  if (unit == "ms") scale = 1e-3;
  if (!x || scale == 0.0) {
    throw Error("expected a duration like 8s or 500ms, got \"" + std::string(text) + "\"", {}, 0,
                field);
  }
  if (!(*x > 0.0))
    throw Error("expected a duration > 0, got \"" + std::string(text) + "\"", {}, 0, field);
  return *x * scale;
}

std::pair<double, double> parse_pose_deg(std::string_view text, const std::string& field) {
  const std::size_t comma = text.find(',');
  const std::optional<double> g1 =
      comma == std::string_view::npos ? std::nullopt : to_number(trim(text.substr(0, comma)));
  const std::optional<double> g2 =
      comma == std::string_view::npos ? std::nullopt : to_number(trim(text.substr(comma + 1)));
  if (!g1 || !g2) {
    throw Error("expected two angles in degrees like 65,90, got \"" + std::string(text) + "\"", {},
                0, field);
  }
  return {*g1, *g2};
}

std::string option_error(const Error& error) { return error.field() + ": " + error.message(); }

}  // namespace alphainv::apps
