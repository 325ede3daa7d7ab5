#include "alphainv/simulate/recorded_run.hpp"

#include <cmath>

#include <Eigen/Dense>

#include "alphainv/error.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/reference.hpp"

namespace alphainv {

InitialState initial_state_of(const RunData& run) {
  InitialState s;
  if (run.size() == 0) return s;
  s.theta = run.theta[0];
  // θ̇(t0) from a least-squares quadratic through the first 10 ms (at least 4 samples): a line
  // would take a run that starts at rest and accelerates for one already moving.
  std::size_t m = 1;
  while (m < run.size() && (run.t[m] - run.t[0] <= 10e-3 || m < 4)) ++m;
  if (m < 3) return s;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(m), 3);
  Eigen::VectorXd y(static_cast<Eigen::Index>(m));
  const double span = run.t[m - 1] - run.t[0];
  for (std::size_t k = 0; k < m; ++k) {
    const double x = (run.t[k] - run.t[0]) / span;  // scaled to [0, 1] for conditioning
    const auto i = static_cast<Eigen::Index>(k);
    a(i, 0) = 1.0;
    a(i, 1) = x;
    a(i, 2) = x * x;
    y(i) = run.theta[k];
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(y);
  if (std::isfinite(c(1)) && span > 0) s.theta_dot = c(1) / span;
  return s;
}

MeasuredStart measured_state_at(const RunData& run, std::size_t k, double half_span_s) {
  MeasuredStart s;
  if (k >= run.size() || !(half_span_s > 0.0)) return s;
  const double t0 = run.t[k];
  std::size_t a = k, b = k;
  while (a > 0 && t0 - run.t[a - 1] <= half_span_s * (1.0 + 1e-9)) --a;
  while (b + 1 < run.size() && run.t[b + 1] - t0 <= half_span_s * (1.0 + 1e-9)) ++b;
  // Both sides covered (at least half the span each) and enough samples for a quartic.
  if (a == k || b == k || t0 - run.t[a] < 0.5 * half_span_s || run.t[b] - t0 < 0.5 * half_span_s ||
      b - a + 1 < 8)
    return s;
  const auto m = static_cast<Eigen::Index>(b - a + 1);
  Eigen::MatrixXd x(m, 5);
  Eigen::VectorXd y(m);
  for (std::size_t j = a; j <= b; ++j) {
    const double u = (run.t[j] - t0) / half_span_s;  // scaled to [−1, 1] for conditioning
    const auto i = static_cast<Eigen::Index>(j - a);
    x(i, 0) = 1.0;
    x(i, 1) = u;
    x(i, 2) = u * u;
    x(i, 3) = u * u * u;
    x(i, 4) = u * u * u * u;
    y(i) = run.theta[j];
  }
  const Eigen::VectorXd c = x.colPivHouseholderQr().solve(y);
  if (std::isfinite(c(0)) && std::isfinite(c(1))) {
    s.theta_rad = c(0);
    s.theta_dot_rad_s = c(1) / half_span_s;
  }
  return s;
}

InitialState initial_state_of(const RunData& run, const MeasuredStart& start,
                              std::vector<double> command_history) {
  InitialState s = initial_state_of(run);
  if (std::isfinite(start.theta_rad)) s.theta = start.theta_rad;
  if (std::isfinite(start.theta_dot_rad_s)) s.theta_dot = start.theta_dot_rad_s;
  s.command_history = std::move(command_history);
  return s;
}

SimulationResult simulate_recorded_run(const JointModelAtPose& model, const Controller& controller,
                                       const RunData& run, const InitialState& initial,
                                       const SimulationOptions& options,
                                       KnownInputUse known_inputs) {
  SimulationResult bad;
  if (run.size() == 0) {
    bad.message = "the run has no samples";
    return bad;
  }
  KnownInputSeries known;
  if (known_inputs == KnownInputUse::kUse) {
    try {
      known = KnownInputSeries::of_run(run);
    } catch (const Error& e) {
      bad.message = e.what();
      return bad;
    }
  }
  if (is_open_loop(controller)) {
    const SampledReference command(run.t, run.v);
    return simulate_open_loop(model, command, run.t, initial, options, known);
  }
  const SampledReference reference(run.t, run.r);
  return simulate(model, controller, reference, run.t, initial, options, known);
}

}  // namespace alphainv
