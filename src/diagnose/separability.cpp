#include "alphainv/diagnose/separability.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "common/format.hpp"

namespace alphainv {

double spanned_share(const std::vector<double>& y, const std::vector<std::vector<double>>& xs) {
  const auto n = static_cast<Eigen::Index>(y.size());
  if (n == 0 || xs.empty()) return std::numeric_limits<double>::quiet_NaN();
  Eigen::MatrixXd x(n, static_cast<Eigen::Index>(xs.size()));
  for (std::size_t j = 0; j < xs.size(); ++j) {
    if (xs[j].size() != y.size()) return std::numeric_limits<double>::quiet_NaN();
    x.col(static_cast<Eigen::Index>(j)) = Eigen::Map<const Eigen::VectorXd>(xs[j].data(), n);
  }
  const Eigen::Map<const Eigen::VectorXd> yv(y.data(), n);
  const double yy = yv.squaredNorm();
  if (!(yy > 0.0) || !std::isfinite(yy)) return std::numeric_limits<double>::quiet_NaN();
  // (column-pivoted QR: sensitivity columns of very different scales, some nearly dependent)
  const Eigen::VectorXd b = x.colPivHouseholderQr().solve(yv);
  return 1.0 - (yv - x * b).squaredNorm() / yy;
}

std::vector<NotSeparable> not_separable(const Effects& model, const std::vector<EffectKind>& named,
                                        const std::vector<std::pair<EffectKind, Effects>>& candidates,
                                        const std::vector<double>& theta, const std::vector<double>& theta_dot,
                                        double share) {
  std::vector<NotSeparable> out;
  const std::size_t n = std::min(theta.size(), theta_dot.size());
  if (n == 0) return out;
  // The named effects' sensitivities ∂n/∂p (central differences; the other terms cancel).
  std::vector<std::vector<double>> columns;
  std::vector<EffectKind> column_kind;
  for (EffectKind k : named) {
    if (effect_spec(k).role != EffectRole::kTorque) continue;
    for (const auto& par : effect_parameters(k)) {
      const double x = model.*(par.member);
      const double h = 1e-6 * std::max(std::abs(x), 1e-3);
      Effects up = model, down = model;
      up.*(par.member) = x + h;
      down.*(par.member) = x - h;
      std::vector<double> col(n);
      for (std::size_t s = 0; s < n; ++s)
        col[s] = (effect_torque(up, theta[s], theta_dot[s]) - effect_torque(down, theta[s], theta_dot[s])) / (2.0 * h);
      columns.push_back(std::move(col));
      column_kind.push_back(k);
    }
  }
  if (columns.empty()) return out;
  for (const auto& [kind, fitted] : candidates) {
    if (kind == EffectKind::kNone || effect_spec(kind).role != EffectRole::kTorque) continue;
    if (std::find(named.begin(), named.end(), kind) != named.end()) continue;
    // Nested forms (a generalisation and the effect it generalises, EffectSpec::generalises):
    // one spanned by its nested named effect alone is that form (an asymmetric friction fitted
    // symmetric is the Coulomb friction named), not a confusion with it: skipped below.
    const auto nested_with = [&](EffectKind k) {
      return effect_spec(kind).generalises(k) || effect_spec(k).generalises(kind);
    };
    Effects only;  // the candidate's own term alone
    for (const auto& par : effect_parameters(kind, true)) only.*(par.member) = fitted.*(par.member);
    std::vector<double> y(n);
    const auto torque_of_only = [&] {
      double largest = 0.0;
      for (std::size_t s = 0; s < n; ++s) {
        y[s] = effect_torque(only, theta[s], theta_dot[s]);
        largest = std::max(largest, std::abs(y[s]));
      }
      return largest;
    };
    // A candidate fitted to nothing (an offset that gravity's θ0 took up): its form at a unit
    // magnitude (the share does not depend on it), with its fitted shape.
    if (!effect_active(only, kind) || !(torque_of_only() > 0.0)) {
      only.*(effect_spec(kind).parameters[0].member) = 1.0;
      if (!(torque_of_only() > 0.0)) continue;
    }
    const double r2 = spanned_share(y, columns);
    if (!(r2 >= share)) continue;
    NotSeparable ns;
    ns.effect = kind;
    ns.share = r2;
    // The named effects that span it: those whose columns alone reach the share.
    std::string names;
    for (EffectKind k : named) {
      if (std::find(column_kind.begin(), column_kind.end(), k) == column_kind.end()) continue;
      std::vector<std::vector<double>> own;
      for (std::size_t j = 0; j < columns.size(); ++j)
        if (column_kind[j] == k) own.push_back(columns[j]);
      if (spanned_share(y, own) >= share) ns.from.push_back(k);
    }
    if (std::any_of(ns.from.begin(), ns.from.end(), nested_with)) continue;  // that form itself
    if (ns.from.empty()) {  // only together
      for (EffectKind k : named)
        if (std::find(column_kind.begin(), column_kind.end(), k) != column_kind.end()) ns.from.push_back(k);
    }
    for (EffectKind k : ns.from) names += (names.empty() ? "" : " + ") + std::string(effect_name(k));
    // A generalisation of a named effect that the others make up: its part beyond that form (an
    // asymmetric friction's asymmetry, a constant while moving) is what they take up (gravity's
    // θ0 over a small stroke).
    std::string beyond;
    for (EffectKind k : named) {
      if (effect_spec(kind).generalises(k)) {
        beyond = std::string(" (its part beyond ") + effect_name(k) + "'s form is taken up by the others)";
        break;
      }
    }
    ns.message = std::string(effect_name(kind)) + " is not separable from " + names + beyond +
                 " on these data: its torque lies within what refitting " + names +
                 " makes (share " + common::format("%.5f", r2) + " of its energy over the fit runs' states), so they fit "
                 "these data alike with or without it; runs over other states (a wider stroke, "
                 "other speeds) would tell them apart";
    out.push_back(std::move(ns));
  }
  return out;
}

}  // namespace alphainv
