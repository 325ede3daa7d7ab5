#include "alphainv/identify/gravity_search.hpp"

#include <nlopt.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "alphainv/identify/time_domain_fit.hpp"
#include "alphainv/model/plant_input.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/recorded_run.hpp"
#include "common/parallel_for.hpp"

namespace alphainv {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct LocalSearch {
  const GravityCost* cost;
  int evaluations = 0;
  GravityPoint best{0.0, 0.0, kInf};
};

double local_objective(unsigned, const double* x, double*, void* p) {
  auto& s = *static_cast<LocalSearch*>(p);
  ++s.evaluations;
  const double c = (*s.cost)(x[0], x[1]);
  if (c < s.best.cost) s.best = normal_gravity(x[0], x[1]), s.best.cost = c;
  return std::isfinite(c) ? c : 1e300;
}

}  // namespace

GravityPoint normal_gravity(double g, double theta0) {
  GravityPoint p;
  if (g < 0.0) {
    g = -g;
    theta0 += kPi;
  }
  p.g = g;
  p.theta0 = std::remainder(theta0, 2.0 * kPi);  // [−π, π]
  if (p.theta0 <= -kPi) p.theta0 += 2.0 * kPi;
  return p;
}

std::vector<double> gravity_grid_amplitudes(double v_max) {
  std::vector<double> a;
  for (double f : {0.03, 0.07, 0.15, 0.3, 0.6, 1.0}) a.push_back(f * v_max);
  return a;
}

GravitySearchResult search_gravity(const GravityCost& cost, const GravitySearchOptions& options,
                                   const std::vector<GravityPoint>& starts) {
  GravitySearchResult r;
  std::vector<GravityPoint>& pts = r.grid;
  for (double g : options.amplitudes) {
    if (!(g > 0.0) || !std::isfinite(g)) continue;
    for (std::size_t k = 0; k < options.phases; ++k) {
      pts.push_back({g, -kPi + 2.0 * kPi * static_cast<double>(k + 1) /
                                   static_cast<double>(options.phases), kInf});
    }
  }
  for (const GravityPoint& s : starts) {
    if (std::isfinite(s.g) && std::isfinite(s.theta0) && s.g != 0.0) {
      pts.push_back(normal_gravity(s.g, s.theta0));
      pts.back().cost = kInf;
    }
  }
  if (pts.empty()) {
    r.message = "no grid point: the amplitudes must be > 0";
    return r;
  }
  common::parallel_for(pts.size(), options.threads, [&](std::size_t i) {
    const double c = cost(pts[i].g, pts[i].theta0);
    pts[i].cost = std::isfinite(c) ? c : kInf;
  });
  r.evaluations = static_cast<int>(pts.size());
  std::vector<std::size_t> order(pts.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return pts[a].cost < pts[b].cost; });
  r.grid_best = pts[order.front()];
  r.best = r.grid_best;
  if (!std::isfinite(r.grid_best.cost)) {
    r.message = "the model failed at every grid point";
    return r;
  }
  r.ok = true;
  // Local refinement in (g, θ0) from the best grid points, steps of a third of the grid's
  // spacing in phase and 30 % in amplitude; θ0 unbounded (periodic), g ≥ 0.
  const double phase_step = 2.0 * kPi / static_cast<double>(std::max<std::size_t>(options.phases, 1));
  std::vector<GravityPoint> refined(std::min(options.refine_from, order.size()));
  std::vector<int> evals(refined.size(), 0);
  common::parallel_for(refined.size(), options.threads, [&](std::size_t j) {
    const GravityPoint& s = pts[order[j]];
    LocalSearch ls{&cost, 0, s};
    if (!std::isfinite(s.cost)) {
      refined[j] = s;
      return;
    }
    nlopt_opt opt = nlopt_create(NLOPT_LN_NELDERMEAD, 2);
    if (opt == nullptr) {
      refined[j] = s;
      return;
    }
    double x[2] = {s.g, s.theta0};
    const double lower[2] = {0.0, -kInf}, upper[2] = {kInf, kInf};
    const double step[2] = {0.3 * s.g, phase_step / 3.0};
    nlopt_set_lower_bounds(opt, lower);
    nlopt_set_upper_bounds(opt, upper);
    nlopt_set_initial_step(opt, step);
    nlopt_set_min_objective(opt, local_objective, &ls);
    nlopt_set_xtol_rel(opt, 1e-4);
    nlopt_set_ftol_rel(opt, 1e-8);
    nlopt_set_maxeval(opt, std::max(1, options.max_refine_evaluations));
    double f = 0.0;
    (void)nlopt_optimize(opt, x, &f);  // the best point seen is kept in ls
    nlopt_destroy(opt);
    refined[j] = ls.best;
    evals[j] = ls.evaluations;
  });
  for (std::size_t j = 0; j < refined.size(); ++j) {
    r.evaluations += evals[j];
    if (refined[j].cost < r.best.cost) r.best = refined[j];
  }
  return r;
}

TimeDomainGravityCost::TimeDomainGravityCost(const Dataset& dataset,
                                             const std::vector<RunData>& data, const Effects& base,
                                             const SimulationOptions& simulation)
    : base_(base), simulation_(simulation) {
  base_.gravity_v = 0.0;
  base_.gravity_theta0_rad = 0.0;
  for (std::size_t i = 0; i < dataset.runs.size() && i < data.size(); ++i) {
    const RunData& d = data[i];
    const Controller& ctl = dataset.runs[i].controller;
    if (d.size() < 20 || !(ctl.kp > 0.0 || ctl.ki > 0.0 || ctl.kd > 0.0)) continue;
    Run r{&d, ctl, {}, {}, {}, {}};
    local_quadratic_derivatives(d.t, d.theta, 0.01, r.theta_dot, r.theta_ddot);
    if (discovered_memory_active(base_)) {
      r.memory_v.resize(d.size());
      discovered_memory_torque_along(base_, d.t.data(), r.theta_dot.data(), d.size(), r.memory_v.data());
    }
    for (std::size_t k = 0; k < d.size(); ++k) {
      // The first and last 20 ms (one-sided fits) left out.
      if (d.t[k] - d.t.front() < 0.02 || d.t.back() - d.t[k] < 0.02) continue;
      if (!std::isfinite(r.theta_dot[k]) || !std::isfinite(r.theta_ddot[k])) continue;
      r.samples.push_back(k);
      v_max_ = std::max(v_max_, std::abs(d.v[k]));
    }
    runs_.push_back(std::move(r));
  }
}

bool TimeDomainGravityCost::regress(double g, double theta0, double& c, double& beta_tilde) const {
  Effects e = base_;
  e.gravity_v = g;
  e.gravity_theta0_rad = theta0;
  // θ̈ = −C·θ̇ + β̃·u: normal equations of the two columns (−θ̇, u).
  double s11 = 0.0, s12 = 0.0, s22 = 0.0, b1 = 0.0, b2 = 0.0;
  for (const Run& r : runs_) {
    const RunData& d = *r.data;
    const KnownInputSeries known = KnownInputSeries::of_run(d);
    for (std::size_t k : r.samples) {
      const double u =
          plant_input(e, d.t[k], d.v[k], d.theta[k], r.theta_dot[k], known.at_sample(k)) + r.memory_at(k);
      const double x1 = -r.theta_dot[k], y = r.theta_ddot[k];
      s11 += x1 * x1, s12 += x1 * u, s22 += u * u, b1 += x1 * y, b2 += u * y;
    }
  }
  const double det = s11 * s22 - s12 * s12;
  if (!(std::abs(det) > 1e-12 * s11 * s22)) return false;
  c = (b1 * s22 - b2 * s12) / det;
  beta_tilde = (s11 * b2 - s12 * b1) / det;
  return c > 0.0 && beta_tilde > 0.0 && std::isfinite(c) && std::isfinite(beta_tilde);
}

double TimeDomainGravityCost::operator()(double g, double theta0) const {
  double c = 0.0, bt = 0.0;
  if (runs_.empty() || !regress(g, theta0, c, bt)) return kInf;
  JointModelAtPose m;
  m.use_alpha = false;
  m.c_linear = c;
  m.beta_tilde_linear = bt;
  m.effects = base_;
  m.effects.gravity_v = g;
  m.effects.gravity_theta0_rad = theta0;
  double sse = 0.0;
  for (const Run& r : runs_) {
    const RunData& d = *r.data;
    const SimulationResult s = simulate_recorded_run(m, r.controller, d, initial_state_of(d),
                                                     simulation_);
    if (!s.ok || s.theta.size() != d.size()) return kInf;
    for (std::size_t k = 0; k < d.size(); ++k) sse += (d.theta[k] - s.theta[k]) * (d.theta[k] - s.theta[k]);
  }
  return std::isfinite(sse) ? sse : kInf;
}

bool TimeDomainGravityCost::equation_error_start(GravityPoint& start) const {
  // θ̈ = −C·θ̇ + β̃·u0 − β̃g·cos θ0·sin θ − β̃g·sin θ0·cos θ (u0: u without gravity).
  Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
  Eigen::Vector4d b = Eigen::Vector4d::Zero();
  for (const Run& r : runs_) {
    const RunData& d = *r.data;
    const KnownInputSeries known = KnownInputSeries::of_run(d);
    for (std::size_t k : r.samples) {
      const double u0 =
          plant_input(base_, d.t[k], d.v[k], d.theta[k], r.theta_dot[k], known.at_sample(k)) + r.memory_at(k);
      const Eigen::Vector4d x(-r.theta_dot[k], u0, -std::sin(d.theta[k]), -std::cos(d.theta[k]));
      a += x * x.transpose();
      b += x * r.theta_ddot[k];
    }
  }
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(a);
  if (lu.rank() < 4) return false;
  const Eigen::Vector4d p = lu.solve(b);
  if (!(p(1) > 0.0)) return false;
  // p(2) = β̃g·cos θ0, p(3) = β̃g·sin θ0.
  start = normal_gravity(std::hypot(p(2), p(3)) / p(1), std::atan2(p(3), p(2)));
  start.cost = kInf;
  return std::isfinite(start.g) && std::isfinite(start.theta0);
}

}  // namespace alphainv
