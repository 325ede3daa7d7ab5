#include "alphainv/device/sim_push.hpp"

#include <algorithm>
#include <cstdlib>

#include "alphainv/error.hpp"

namespace alphainv::device {

namespace {

/// The number `text` spells in full (an optional trailing `unit`), or NaN.
double number(std::string text, char unit) {
  if (unit != '\0' && !text.empty() && text.back() == unit) text.pop_back();
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(x)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return x;
}

}  // namespace

SimPush parse_sim_push(const std::string& text, const std::string& field) {
  const std::string expected =
      "expected ramp:RATE[,start=S][,max=V], hand:SPEED[,stiffness=K][,damping=B][,start=S]"
      "[,max=V] or constant:V[,start=S] (RATE [command unit/s] "
      "and V [command unit] nonzero, either sign; S >= 0 [s]), got '" + text + "'";
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos) throw Error(expected, {}, 0, field);
  SimPush push;
  const std::string kind = text.substr(0, colon);
  if (kind == "ramp") {
    push.kind = SimPush::Kind::kRamp;
  } else if (kind == "constant") {
    push.kind = SimPush::Kind::kConstant;
  } else if (kind == "hand") {
    push.kind = SimPush::Kind::kHand;
  } else {
    throw Error(expected, {}, 0, field);
  }
  std::size_t start = colon + 1;
  bool first = true;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find(',', start), text.size());
    const std::string item = text.substr(start, end - start);
    start = end + 1;
    if (first) {
      push.level_v = number(item, '\0');
      first = false;
      if (!std::isfinite(push.level_v) || push.level_v == 0.0) throw Error(expected, {}, 0, field);
      continue;
    }
    const std::size_t eq = item.find('=');
    const std::string key = item.substr(0, eq == std::string::npos ? item.size() : eq);
    const double x = eq == std::string::npos ? std::numeric_limits<double>::quiet_NaN()
                                             : number(item.substr(eq + 1), key == "start" ? 's' : '\0');
    if (key == "start" && x >= 0.0) {
      push.start_s = x;
    } else if (key == "max" && kind != "constant" && x > 0.0) {
      push.max_v = x;
    } else if (key == "stiffness" && kind == "hand" && x > 0.0) {
      push.stiffness_v_per_rad = x;
    } else if (key == "damping" && kind == "hand" && x >= 0.0) {
      push.damping_v_s_per_rad = x;
    } else {
      throw Error(expected + ": bad item '" + item + "'", {}, 0, field);
    }
  }
  return push;
}

}  // namespace alphainv::device
