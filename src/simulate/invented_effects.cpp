#include "alphainv/simulate/invented_effects.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <vector>

#include "alphainv/error.hpp"
#include "alphainv/model/detail/field_checks.hpp"

namespace alphainv {

namespace {

struct InventedParameter {
  const char* name;
  double InventedEffect::*member;
};

constexpr InventedParameter kParameters[] = {
    {"level_v", &InventedEffect::level_v},
    {"breakaway_v", &InventedEffect::breakaway_v},
    {"velocity_rad_s", &InventedEffect::velocity_rad_s},
    {"stiffness_v_per_rad", &InventedEffect::stiffness_v_per_rad},
    {"lag_s", &InventedEffect::lag_s},
    {"drift", &InventedEffect::drift},
};

const char* kind_name(InventedKind k) {
  switch (k) {
    case InventedKind::kNone: return "none";
    case InventedKind::kLuGre: return "lugre";
    case InventedKind::kDrift: return "drift";
    case InventedKind::kHysteresis: return "hysteresis";
  }
  return "none";
}

/// The parameters a kind uses.
std::vector<std::string> used_by(InventedKind k) {
  switch (k) {
    case InventedKind::kLuGre: return {"level_v", "breakaway_v", "velocity_rad_s", "stiffness_v_per_rad"};
    case InventedKind::kDrift: return {"level_v", "velocity_rad_s", "drift"};
    case InventedKind::kHysteresis: return {"level_v", "velocity_rad_s", "lag_s"};
    case InventedKind::kNone: return {};
  }
  return {};
}

double algebraic_sign(double x, double v) { return x / std::sqrt(x * x + v * v); }

}  // namespace

std::string InventedEffect::text() const {
  if (!active()) return "none";
  std::string out = std::string(kind_name(kind)) + ":";
  bool first = true;
  for (const std::string& name : used_by(kind)) {
    for (const InventedParameter& p : kParameters) {
      if (name != p.name) continue;
      out += (first ? "" : ",") + name + "=" + detail::num(this->*p.member);
      first = false;
    }
  }
  return out;
}

InventedEffect parse_invented_effect(const std::string& spec, const std::string& option) {
  InventedEffect e;
  const std::size_t colon = spec.find(':');
  const std::string kind = spec.substr(0, colon);
  for (InventedKind k : {InventedKind::kLuGre, InventedKind::kDrift, InventedKind::kHysteresis}) {
    if (kind == kind_name(k)) e.kind = k;
  }
  if (!e.active()) {
    throw Error("expected lugre, drift or hysteresis[:PARAM=VALUE,...], found \"" + spec + "\"", {},
                0, option);
  }
  const std::vector<std::string> used = used_by(e.kind);
  if (colon != std::string::npos) {
    const std::string items = spec.substr(colon + 1);
    std::size_t start = 0;
    while (start <= items.size()) {
      const std::size_t end = std::min(items.find(',', start), items.size());
      const std::string item = items.substr(start, end - start);
      const std::size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      const InventedParameter* param = nullptr;
      for (const InventedParameter& p : kParameters) {
        if (key == p.name) param = &p;
      }
      bool known = false;
      for (const std::string& u : used) known = known || u == key;
      if (eq == std::string::npos || param == nullptr || !known) {
        std::string names;
        for (const std::string& u : used) names += (names.empty() ? "" : ", ") + u;
        throw Error("expected PARAM=VALUE with PARAM one of " + names + ", found \"" + item + "\"",
                    {}, 0, option);
      }
      const std::string text = item.substr(eq + 1);
      char* rest = nullptr;
      const double x = std::strtod(text.c_str(), &rest);
      if (text.empty() || rest == nullptr || *rest != '\0' || !std::isfinite(x)) {
        throw Error("expected a finite number for " + key + ", found \"" + text + "\"", {}, 0, option);
      }
      e.*(param->member) = x;
      start = end + 1;
    }
  }
  const std::string field = option + " " + kind_name(e.kind) + ":";
  detail::require_positive(field + "level_v", e.level_v);
  detail::require_positive(field + "velocity_rad_s", e.velocity_rad_s);
  detail::require_positive(field + "stiffness_v_per_rad", e.stiffness_v_per_rad);
  detail::require_positive(field + "lag_s", e.lag_s);
  if (e.kind == InventedKind::kLuGre && !(e.breakaway_v >= e.level_v)) {
    detail::bad(field + "breakaway_v", "breakaway_v >= level_v", e.breakaway_v);
  }
  if (!(e.drift >= 0.0 && e.drift < 1.0)) detail::bad(field + "drift", "0 <= drift < 1", e.drift);
  return e;
}

std::function<double(double, double, double)> invented_torque(const InventedEffect& e,
                                                              std::size_t run_index) {
  switch (e.kind) {
    case InventedKind::kNone: return [](double, double, double) { return 0.0; };
    case InventedKind::kLuGre: {
      // z advanced over the previous tick with that tick's θ̇ held: ż = θ̇ − a·z, a = σ0|θ̇|/g.
      auto state = std::make_shared<std::array<double, 3>>(std::array<double, 3>{0.0, 0.0, -1.0});
      return [e, state](double t, double, double om) {
        double& z = (*state)[0];
        double& om_prev = (*state)[1];
        double& t_prev = (*state)[2];
        if (t_prev >= 0.0 && t > t_prev) {
          const double h = t - t_prev;
          const double g =
              e.level_v + (e.breakaway_v - e.level_v) * std::exp(-std::abs(om_prev / e.velocity_rad_s));
          const double a = e.stiffness_v_per_rad * std::abs(om_prev) / g;
          if (a > 0.0) {
            const double zss = om_prev / a;
            z = zss + (z - zss) * std::exp(-a * h);
          } else {
            z += om_prev * h;
          }
        }
        om_prev = om;
        t_prev = t;
        return -e.stiffness_v_per_rad * z;
      };
    }
    case InventedKind::kDrift: {
      const double frac = std::fmod(0.618 * static_cast<double>(run_index + 1), 1.0);
      const double level = e.level_v * (1.0 + e.drift * (2.0 * frac - 1.0));
      return [e, level](double, double, double om) { return -level * algebraic_sign(om, e.velocity_rad_s); };
    }
    case InventedKind::kHysteresis: {
      auto state = std::make_shared<std::array<double, 2>>(std::array<double, 2>{0.0, -1.0});
      return [e, state](double t, double, double om) {
        double& lag = (*state)[0];
        double& t_prev = (*state)[1];
        if (t_prev >= 0.0 && t > t_prev) lag = om + (lag - om) * std::exp(-(t - t_prev) / e.lag_s);
        else if (t_prev < 0.0) lag = om;
        t_prev = t;
        return -e.level_v * algebraic_sign(lag, e.velocity_rad_s);
      };
    }
  }
  return [](double, double, double) { return 0.0; };
}

}  // namespace alphainv
