#include "alphainv/simulate/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

#include <gtest/gtest.h>

#include "alphainv/identify/local_linear.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv {
namespace {

/// The paper's 65°/90° pose (true angles 60.08°, 87.00°): I = 0.004366, C_linear = 6.242.
JointModelAtPose paper_pose_model(bool use_alpha) {
  return model_at_pose(paper_linear_model(), paper_alpha_model(), deg_to_rad(60.08),
                       deg_to_rad(87.00), use_alpha);
}

double max_abs_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0;
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return d;
}

TEST(Simulate, PaperPoseMatchesTable10) {
  const JointModelAtPose m = paper_pose_model(true);
  EXPECT_NEAR(m.inertia, 0.004366, 0.0005 * 0.004366);
  EXPECT_NEAR(m.c_linear, 6.242, 0.005 * 6.242);
  EXPECT_NEAR(m.beta_tilde_linear, 229.04, 0.005 * 229.04);
}

TEST(Simulate, TheDiscoveredMemoryTermsNeedTheDigitalLoop) {
  // Their state advances once per tick (virtual_omni.hpp): the continuous law refuses them by
  // name, the digital loop runs them.
  JointModelAtPose m = paper_pose_model(false);
  m.effects.discovered_lag_sign_v = -0.005;
  m.effects.discovered_lag_s = 0.01;
  const SineReference ref(0.07, 2.0);
  const auto times = uniform_times(1.0, 1e-3);
  for (Integrator integ : {Integrator::kFixedPointRk4, Integrator::kCvode}) {
    SimulationOptions opt;
    opt.integrator = integ;
    const SimulationResult res = simulate(m, Controller{}, ref, times, {}, opt);
    EXPECT_FALSE(res.ok);
    EXPECT_NE(res.message.find("discovered_lag_sign_v"), std::string::npos) << res.message;
  }
  SimulationOptions digital;
  digital.loop_period_s = 1e-3;
  const SimulationResult with = simulate(m, Controller{}, ref, times, {}, digital);
  ASSERT_TRUE(with.ok) << with.message;
  m.effects.discovered_lag_sign_v = 0.0;
  const SimulationResult without = simulate(m, Controller{}, ref, times, {}, digital);
  ASSERT_TRUE(without.ok) << without.message;
  // A friction that lags the velocity (0.005 V against kp·0.07 = 0.14 V of the P law): the
  // tracking moves by a visible fraction of a milliradian, not by rounding.
  EXPECT_GT(max_abs_diff(with.theta, without.theta), 1e-4);
}

TEST(Simulate, LinearStepMatchesAnalyticSolution) {
  // θ̈ + Cθ̇ + βθ = βA from θ(0) = −A, θ̇(0) = 0, β = β̃ kp (eq. (47)).
  JointModelAtPose m = paper_pose_model(false);
  Controller ctl;  // kp = 2
  const double a = 0.07, c = m.c_linear, beta = m.beta_tilde_linear * ctl.kp;
  const double wn = std::sqrt(beta), zeta = c / (2 * wn), wd = wn * std::sqrt(1 - zeta * zeta);
  const SquareReference ref(a, 0.25);
  const auto times = uniform_times(1.9, 1e-3);
  for (Integrator integ : {Integrator::kFixedPointRk4, Integrator::kCvode}) {
    SimulationOptions opt;
    opt.integrator = integ;
    const SimulationResult res = simulate(m, ctl, ref, times, {-a, 0.0, 0.0}, opt);
    ASSERT_TRUE(res.ok) << res.message;
    double worst = 0.0;
    for (std::size_t k = 0; k < times.size(); ++k) {
      const double t = times[k];
      const double exact =
          a - 2 * a * std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta * wn / wd * std::sin(wd * t));
      worst = std::max(worst, std::abs(res.theta[k] - exact));
    }
    EXPECT_LT(worst, 1e-7) << "integrator " << static_cast<int>(integ);
  }
}

TEST(Simulate, LinearSineSteadyStateMatchesEquation18) {
  JointModelAtPose m = paper_pose_model(false);
  Controller ctl;
  const double ar = 0.07, f = 3.0, w = 2 * M_PI * f;
  const double c = m.c_linear, beta = m.beta_tilde_linear * ctl.kp;
  const double den = (beta - w * w) * (beta - w * w) + c * c * w * w;
  const double a2 = beta * ar * (beta - w * w) / den, a1 = -beta * ar * c * w / den;
  const SineReference ref(ar, f);
  const auto times = uniform_times(9.0, 1e-3);
  const SimulationResult res = simulate(m, ctl, ref, times);
  ASSERT_TRUE(res.ok);
  const IndexRange win = steady_state_window(times, f, 6.0);  // transient e^{-C t/2} < 1e-8
  const SineFit fit = fit_sine(times.data() + win.begin, res.theta.data() + win.begin, win.size(), w);
  EXPECT_NEAR(fit.a1, a1, 1e-6);
  EXPECT_NEAR(fit.a2, a2, 1e-6);
}

TEST(Simulate, FixedPointAndCvodeAgreeOnPaperSineSweep) {
  const JointModelAtPose m = paper_pose_model(true);
  Controller ctl;
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) {
    const SineReference ref(0.07, f);
    const auto times = uniform_times(3.0, 1e-3);
    SimulationOptions fp, cv;
    cv.integrator = Integrator::kCvode;
    const SimulationResult a = simulate(m, ctl, ref, times, {}, fp);
    const SimulationResult b = simulate(m, ctl, ref, times, {}, cv);
    ASSERT_TRUE(a.ok && b.ok) << a.message << b.message;
    EXPECT_LT(max_abs_diff(a.theta, b.theta), 1e-3) << f << " Hz";
    EXPECT_EQ(a.fixed_point_not_converged, 0);
    EXPECT_GE(a.max_fixed_point_iterations, 2);  // the scheme really iterates
    EXPECT_LT(a.mean_iterations(), 10.0);
  }
}

TEST(Simulate, FixedPointAndCvodeAgreeOnPaperSquareWave) {
  const JointModelAtPose m = paper_pose_model(true);
  Controller ctl;
  const SquareReference ref(0.07, 0.25);
  const auto times = uniform_times(8.0, 1e-3);
  SimulationOptions cv;
  cv.integrator = Integrator::kCvode;
  const SimulationResult a = simulate(m, ctl, ref, times, {-0.07, 0.0, 0.0});
  const SimulationResult b = simulate(m, ctl, ref, times, {-0.07, 0.0, 0.0}, cv);
  ASSERT_TRUE(a.ok && b.ok) << a.message << b.message;
  EXPECT_LT(max_abs_diff(a.theta, b.theta), 1e-3);
  // The α-model settles to the set point after each step (a P loop on an integrating plant).
  EXPECT_NEAR(a.theta[1999], 0.07, 2e-3);
  EXPECT_NEAR(a.theta[3999], -0.07, 2e-3);
}

TEST(Simulate, AlphaModelDampsMoreThanLinearAtLowEnergy) {
  // At low α the α-model's damping exceeds C_linear (Table 10: 16.955 at α = 0 vs 6.242), so the
  // step overshoot is smaller than the linear model's.
  Controller ctl;
  const SquareReference ref(0.07, 0.25);
  const auto times = uniform_times(1.0, 1e-3);
  const auto lin = simulate(paper_pose_model(false), ctl, ref, times, {-0.07, 0.0, 0.0});
  const auto alp = simulate(paper_pose_model(true), ctl, ref, times, {-0.07, 0.0, 0.0});
  const double over_lin = *std::max_element(lin.theta.begin(), lin.theta.end()) - 0.07;
  const double over_alp = *std::max_element(alp.theta.begin(), alp.theta.end()) - 0.07;
  EXPECT_GT(over_lin, 0.0);
  EXPECT_LT(over_alp, over_lin);
  // Reported C and β̃ stay within the model's range at this pose.
  for (double c : alp.damping) {
    EXPECT_GE(c, 3.70);
    EXPECT_LE(c, 16.96);
  }
}

TEST(Simulate, PidWithSaturationAgreesAcrossIntegratorsAndRespectsLimit) {
  JointModelAtPose m = paper_pose_model(true);
  Controller ctl;
  ctl.kp = 3.0;
  ctl.ki = 1.5;
  ctl.kd = 0.02;
  ctl.derivative_on = DerivativeOn::kMeasurement;
  ctl.v_limit = 0.15;
  const SquareReference ref(0.07, 0.5);
  const auto times = uniform_times(4.0, 1e-3);
  SimulationOptions cv;
  cv.integrator = Integrator::kCvode;
  const auto a = simulate(m, ctl, ref, times, {-0.07, 0.0, 0.0});
  const auto b = simulate(m, ctl, ref, times, {-0.07, 0.0, 0.0}, cv);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_LT(max_abs_diff(a.theta, b.theta), 1e-3);
  double vmax = 0.0;
  for (double v : a.v) vmax = std::max(vmax, std::abs(v));
  EXPECT_LE(vmax, 0.15 + 1e-12);
  EXPECT_NEAR(vmax, 0.15, 1e-12);  // the limit is reached after each step
}

TEST(Simulate, SampledReferenceReproducesAnalyticReference) {
  const JointModelAtPose m = paper_pose_model(true);
  Controller ctl;
  const auto times = uniform_times(3.0, 1e-3);
  std::vector<double> r(times.size());
  const SineReference sine(0.07, 2.5);
  for (std::size_t k = 0; k < times.size(); ++k) r[k] = sine.at(times[k]).r;
  const SampledReference sampled(times, r);
  const auto a = simulate(m, ctl, sine, times);
  const auto b = simulate(m, ctl, sampled, times);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_LT(max_abs_diff(a.theta, b.theta), 2e-4);
}

TEST(Simulate, BadInputGivesMessageNotCrash) {
  const JointModelAtPose m = paper_pose_model(true);
  const SineReference ref(0.07, 3.0);
  auto res = simulate(m, Controller{}, ref, {0.0, 0.001, 0.001});
  EXPECT_FALSE(res.ok);
  EXPECT_NE(res.message.find("strictly increasing"), std::string::npos);
  JointModelAtPose bad = m;
  bad.alpha.alpha[2] = 1.0;  // not increasing
  res = simulate(bad, Controller{}, ref, uniform_times(0.1, 1e-3));
  EXPECT_FALSE(res.ok);
  bad = m;
  bad.inertia = 0.0;
  res = simulate(bad, Controller{}, ref, uniform_times(0.1, 1e-3));
  EXPECT_FALSE(res.ok);
  EXPECT_FALSE(simulate(m, Controller{}, ref, {}).ok);
}

TEST(SimulateEffects, OffsetTorqueGivesClosedFormSteadyStateError) {
  // P law, constant r: at rest 0 = β̃(kp(r − θ) + d0), so θ = r + d0/kp.
  JointModelAtPose m = paper_pose_model(false);
  m.effects.offset_v = 0.01;
  Controller ctl;  // kp = 2
  const SampledReference ref({0.0, 6.0}, {0.05, 0.05});
  const auto times = uniform_times(6.0, 1e-3);
  for (Integrator integ : {Integrator::kFixedPointRk4, Integrator::kCvode}) {
    SimulationOptions opt;
    opt.integrator = integ;
    const SimulationResult res = simulate(m, ctl, ref, times, {}, opt);
    ASSERT_TRUE(res.ok) << res.message;
    EXPECT_NEAR(res.theta.back(), 0.05 + 0.01 / 2.0, 1e-7);
  }
}

/// The steady-state response to r = 0.07 sin(2π·3t) of the paper's pose with a delay `tau_s`,
/// checked against the closed form θ/r = β e^{−jωτ} / (β e^{−jωτ} − ω² + jωC), β = β̃·kp, with
/// the default 1 ms steps: v(t − τ) is interpolated linearly between commands at most a step
/// apart, an error of order (ωh)²/8 ≈ 5e-5. Returns the fitted sine.
SineFit expect_delay_response_matches_closed_form(double tau_s) {
  JointModelAtPose m = paper_pose_model(false);
  m.effects.delay_s = tau_s;
  Controller ctl;
  const double ar = 0.07, f = 3.0, w = 2 * M_PI * f;
  const double c = m.c_linear, beta = m.beta_tilde_linear * ctl.kp;
  const std::complex<double> num = beta * std::exp(std::complex<double>(0, -w * tau_s));
  const std::complex<double> h = num / (num - w * w + std::complex<double>(0, w * c));
  const SineReference ref(ar, f);
  const auto times = uniform_times(10.0, 1e-3);
  const SimulationResult res = simulate(m, ctl, ref, times);
  EXPECT_TRUE(res.ok) << res.message;
  if (!res.ok) return {};
  const IndexRange win = steady_state_window(times, f, 7.0);
  const SineFit fit = fit_sine(times.data() + win.begin, res.theta.data() + win.begin, win.size(), w);
  EXPECT_NEAR(fit.a1, ar * h.imag(), 5e-4 * ar) << "tau " << tau_s << " s";
  EXPECT_NEAR(fit.a2, ar * h.real(), 5e-4 * ar) << "tau " << tau_s << " s";
  return fit;
}

TEST(SimulateEffects, DelayMatchesTheClosedFormFrequencyResponse) {
  const SineFit fit = expect_delay_response_matches_closed_form(0.004);
  JointModelAtPose m = paper_pose_model(false);
  Controller ctl;
  const double ar = 0.07, f = 3.0, w = 2 * M_PI * f;
  const SineReference ref(ar, f);
  const auto times = uniform_times(10.0, 1e-3);
  const IndexRange win = steady_state_window(times, f, 7.0);
  // Without the delay the phase is smaller: the delay is really there.
  const SimulationResult nodelay = simulate(m, ctl, ref, times);
  const SineFit f0 = fit_sine(times.data() + win.begin, nodelay.theta.data() + win.begin, win.size(), w);
  EXPECT_GT(std::abs(fit.a1 - f0.a1), 0.05 * ar);
  // CVODE does not take a delay: a message, not a wrong answer.
  SimulationOptions cv;
  cv.integrator = Integrator::kCvode;
  m.effects.delay_s = 0.004;
  const SimulationResult bad = simulate(m, ctl, ref, times, {}, cv);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.message.find("delay"), std::string::npos);
}

TEST(SimulateEffects, DelayShorterThanAStepMatchesTheClosedFormFrequencyResponse) {
  // τ = 0.4 ms inside the 1 ms steps: v(t − τ) between the command at the step's start and the
  // command at t, as accurate as between two steps' commands (the 4 ms test above).
  expect_delay_response_matches_closed_form(0.0004);
}

TEST(SimulateEffects, DelayMuchShorterThanAStepTakesTheStepsOfNoDelay) {
  // The RK4 steps do not depend on τ: a fit's finite-difference Jacobian steps a delay from its
  // bound 0 to ~1e-8 s, and steps bounded by τ made that one simulation cost 1/τ steps (10⁸ on
  // a pendulum run). As τ → 0 the simulation tends to that without delay.
  JointModelAtPose m = paper_pose_model(true);
  Controller ctl;
  const SineReference ref(0.07, 3.0);
  const auto times = uniform_times(0.2, 1e-3);
  const SimulationResult none = simulate(m, ctl, ref, times);
  ASSERT_TRUE(none.ok) << none.message;
  double largest_theta_dot = 0.0;
  for (double x : none.theta_dot) largest_theta_dot = std::max(largest_theta_dot, std::abs(x));
  double diff_before = 0.0;
  for (double tau_s : {1e-6, 1e-7}) {
    m.effects.delay_s = tau_s;
    const SimulationResult tiny = simulate(m, ctl, ref, times);
    ASSERT_TRUE(tiny.ok) << tiny.message;
    EXPECT_EQ(tiny.rhs_evaluations, none.rhs_evaluations) << tau_s;
    // First order in τ: the command lags by τ, θ by about τ·θ̇ (times the loop's gain).
    const double diff = max_abs_diff(tiny.theta, none.theta);
    EXPECT_LT(diff, 10.0 * tau_s * largest_theta_dot) << tau_s;
    if (diff_before > 0.0) {
      EXPECT_LT(diff, 0.2 * diff_before) << tau_s;  // tends to no delay as τ → 0
    }
    diff_before = diff;
  }
}

TEST(SimulateEffects, SaturationGivesTheOpenLoopRampWhileSaturated) {
  // |v| clamped at vmax from rest: θ = θ0 + (β̃ vmax/C)(t − (1 − e^{−Ct})/C) while saturated.
  JointModelAtPose m = paper_pose_model(false);
  m.effects.saturation_v = 0.02;
  Controller ctl;
  const SampledReference ref({0.0, 1.0}, {0.07, 0.07});
  const auto times = uniform_times(0.05, 1e-3);
  const SimulationResult res = simulate(m, ctl, ref, times, {-0.07, 0.0, 0.0});
  ASSERT_TRUE(res.ok) << res.message;
  const double c = m.c_linear, bv = m.beta_tilde_linear * 0.02;
  for (std::size_t k = 0; k < times.size(); k += 10) {
    const double t = times[k];
    EXPECT_NEAR(res.theta[k], -0.07 + bv / c * (t - (1 - std::exp(-c * t)) / c), 1e-9) << t;
  }
}

TEST(SimulateEffects, DigitalLoopReproducesTheVirtualPlant) {
  // The digital loop is the virtual Omni without measurement effects: same θ to rounding.
  VirtualOmniParams p;
  p.effects.coulomb_v = 0.004;
  p.effects.delay_s = 0.0025;
  p.effects.deadzone_v = 0.001;
  p.effects.cogging_v = 0.002;
  p.initial_theta_rad = -0.07;
  Controller ctl;
  ctl.kp = 2.0;
  p.initial_command_v = ctl.kp * (0.07 - -0.07);
  VirtualOmni omni(p);
  const SquareReference ref(0.07, 0.5);
  const RunData run = run_closed_loop(omni, ctl, ref, 3.0);

  JointModelAtPose m = model_at_pose(paper_linear_model(), paper_alpha_model(), deg_to_rad(p.gamma1_deg),
                                     deg_to_rad(p.gamma2_deg), true);
  m.effects = p.effects;
  SimulationOptions opt;
  opt.loop_period_s = 1e-3;
  const SimulationResult res = simulate(m, ctl, ref, run.t, {-0.07, 0.0, 0.0}, opt);
  ASSERT_TRUE(res.ok) << res.message;
  ASSERT_EQ(res.theta.size(), run.theta.size());
  EXPECT_LT(max_abs_diff(res.theta, run.theta), 1e-12);
  EXPECT_LT(max_abs_diff(res.v, run.v), 1e-10);
  // The continuous law (43) differs from the sampled one by the hold's half-tick delay.
  const SimulationResult cont = simulate(m, ctl, ref, run.t, {-0.07, 0.0, 0.0});
  ASSERT_TRUE(cont.ok) << cont.message;
  EXPECT_GT(max_abs_diff(cont.theta, run.theta), 1e-5);
}

}  // namespace
}  // namespace alphainv
