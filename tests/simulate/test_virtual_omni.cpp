#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <functional>
#include <limits>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/simulate/reference.hpp"
#include "alphainv/simulate/virtual_omni.hpp"
#include "support/counting_allocator.hpp"  // the one test file of this program that includes it

namespace alphainv {
namespace {

constexpr double kT = 1e-3;
constexpr double kAr = 0.07;
constexpr double kTwoPi = 2.0 * kPi;

/// r(t) = value.
class ConstantReference final : public Reference {
 public:
  explicit ConstantReference(double value) : value_(value) {}
  ReferenceSample at(double) const override { return {value_, 0.0, 0.0}; }

 private:
  double value_;
};

/// The paper's 65°/90° pose with the global linear model as a "linear" α-model: C, β̃ constant
/// (C = 1/(C̄0 I) = 6.242 1/s, β̃ = 1/I = 229.05).
VirtualOmniParams linear_params() {
  VirtualOmniParams p;
  p.alpha_model = constant_alpha_model(paper_linear_model().c0_bar, 1.0);
  return p;
}

struct LinearPlant {
  double c, bt;
};
LinearPlant linear_plant(const VirtualOmni& omni) {
  return {1.0 / (paper_linear_model().c0_bar * omni.inertia()), 1.0 / omni.inertia()};
}

/// Exact ZOH discretisation of θ̈ + Cθ̇ = β̃u over one tick: x_{k+1} = Ad x_k + Bd u_k.
void zoh(double c, double bt, double T, Eigen::Matrix2d& ad, Eigen::Vector2d& bd) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  m(0, 1) = 1.0;
  m(1, 1) = -c;
  m(1, 2) = bt;
  const Eigen::Matrix3d e = (m * T).exp();
  ad = e.topLeftCorner<2, 2>();
  bd = e.block<2, 1>(0, 2);
}

/// Steady-state sampled response θ_k = A1 cos ωt_k + A2 sin ωt_k of the sampled-data loop
/// x_{k+1} = Ad x_k + Bd kp (r_k − θ_k), r_k = Ar sin ωt_k, from its z-domain transfer function.
void exact_sampled_sine(double c, double bt, double kp, double f, double& a1, double& a2) {
  Eigen::Matrix2d ad;
  Eigen::Vector2d bd;
  zoh(c, bt, kT, ad, bd);
  using cd = std::complex<double>;
  const cd z = std::polar(1.0, kTwoPi * f * kT);
  Eigen::Matrix2cd k = z * Eigen::Matrix2cd::Identity() - ad.cast<cd>();
  k.col(0) += (bd * kp).cast<cd>();  // + Bd kp [1 0]
  const Eigen::Vector2cd x = k.inverse() * (bd * kp).cast<cd>();
  // θ_k = Im(G Ar e^{jωt}) = Ar (Re G sin ωt + Im G cos ωt)
  a1 = kAr * x(0).imag();
  a2 = kAr * x(0).real();
}

/// Options that record the truth columns and nothing else.
ClosedLoopOptions truth_columns() {
  ClosedLoopOptions opt;
  opt.record_truth = true;
  return opt;
}

std::vector<double> sample_plant(VirtualOmni& omni, std::size_t n, double command_v,
                                 std::vector<double>* theta_dot = nullptr) {
  std::vector<double> theta{omni.theta()};
  if (theta_dot) theta_dot->assign(1, omni.theta_dot());
  for (std::size_t k = 0; k < n; ++k) {
    (void)omni.step(command_v);
    theta.push_back(omni.theta());
    if (theta_dot) theta_dot->push_back(omni.theta_dot());
  }
  return theta;
}

// --- (a) linear configuration against analytic solutions
// -------------------------------------------

TEST(VirtualOmni, OpenLoopConstantCommandMatchesClosedForm) {
  // θ̈ + Cθ̇ = β̃v from rest: θ(t) = θ0 + (β̃v/C)(t − (1 − e^{−Ct})/C).
  VirtualOmniParams p = linear_params();
  p.initial_theta_rad = 0.01;
  VirtualOmni omni(p);
  const LinearPlant lin = linear_plant(omni);
  const double v = 0.05;
  const std::vector<double> theta = sample_plant(omni, 2000, v);
  double worst = 0.0;
  for (std::size_t k = 0; k < theta.size(); ++k) {
    const double t = static_cast<double>(k) * kT;
    const double exact = 0.01 + lin.bt * v / lin.c * (t - (1.0 - std::exp(-lin.c * t)) / lin.c);
    worst = std::max(worst, std::abs(theta[k] - exact));
  }
  // RK4 at h = 0.25 ms: local error ~ (hC)^5/120 of the velocity scale; over 2 s of a 3.7 rad ramp.
  EXPECT_LT(worst, 1e-11) << "worst |theta - exact| = " << worst;
  EXPECT_DOUBLE_EQ(omni.damping(), lin.c);
  EXPECT_DOUBLE_EQ(omni.beta_tilde(), lin.bt);
}

TEST(VirtualOmni, SineSteadyStateMatchesExactSampledDataResponse) {
  // The closed loop is a sampled-data system: digital P law at 1 kHz, command held (ZOH). Its
  // exact steady state at the samples follows from the z-domain transfer function; the RK4 plant
  // must reproduce it (after 8 s the transient e^{−Ct/2} is below 2e-11).
  const VirtualOmniParams p = linear_params();
  Controller ctl;  // kp = 2
  for (double f : paper_sine_frequencies_hz()) {
    VirtualOmni omni(p);
    const LinearPlant lin = linear_plant(omni);
    const SineReference ref(kAr, f);
    const RunData d = run_closed_loop(omni, ctl, ref, 10.0);
    const IndexRange win = steady_state_window(d.t, f, 8.0);
    const SineFit fit =
        fit_sine(d.t.data() + win.begin, d.theta.data() + win.begin, win.size(), kTwoPi * f, false);
    double a1 = 0.0, a2 = 0.0;
    exact_sampled_sine(lin.c, lin.bt, ctl.kp, f, a1, a2);
    const double rel = std::hypot(fit.a1 - a1, fit.a2 - a2) / std::hypot(a1, a2);
    EXPECT_LT(rel, 1e-8) << f << " Hz";
    EXPECT_LT(fit.rms_residual, 1e-9) << f << " Hz";
  }
}

TEST(VirtualOmni, SineIdentifiesAsEq18WithTheZeroOrderHoldsHalfSampleDelay) {
  // Eq. (18)/(19)-(20) assume a continuous loop θ̈ + Cθ̇ + βθ = βr. The digital loop holds the
  // command for a tick, which to first order is a delay of T/2: θ/r = βD/(s² + Cs + βD),
  // D = e^{−sT/2} ≈ 1 − sT/2. Matching this to β'/(s² + C's + β') at s = jω gives
  //     C_data = (C − ω²T/2)/(1 + CT/2),   β_data = β/(1 + CT/2),
  // so C_data falls with ω²: −0.7 % at 1.5 Hz, −16 % at 7 Hz for the 65°/90° pose. The plant must
  // show exactly this (to the O((ωT)²) terms neglected: < 0.05 %), and the raw eq. (18) response
  // differs from the simulation by up to βT/(2C) ≈ 3.7 % near resonance.
  const VirtualOmniParams p = linear_params();
  Controller ctl;
  double worst_c = 0.0, worst_beta = 0.0, worst_raw_gain = 0.0;
  for (double f : paper_sine_frequencies_hz()) {
    VirtualOmni omni(p);
    const LinearPlant lin = linear_plant(omni);
    const double beta = lin.bt * ctl.kp, w = kTwoPi * f;
    const SineReference ref(kAr, f);
    const RunData d = run_closed_loop(omni, ctl, ref, 10.0);
    const IndexRange win = steady_state_window(d.t, f, 8.0);
    const SineFit fit =
        fit_sine(d.t.data() + win.begin, d.theta.data() + win.begin, win.size(), w, false);
    const LocalLinearPoint pt = local_linear_point(f, fit.a1, fit.a2, kAr, ctl.kp);
    const double c_pred = (lin.c - w * w * kT / 2.0) / (1.0 + lin.c * kT / 2.0);
    const double beta_pred = beta / (1.0 + lin.c * kT / 2.0);
    worst_c = std::max(worst_c, std::abs(pt.c_data / c_pred - 1.0));
    worst_beta = std::max(worst_beta, std::abs(pt.beta_data / beta_pred - 1.0));
    // Eq. (18)'s continuous amplitude with the true C, β.
    const std::complex<double> g = beta / std::complex<double>(beta - w * w, w * lin.c);
    worst_raw_gain =
        std::max(worst_raw_gain, std::abs(std::hypot(fit.a1, fit.a2) / (kAr * std::abs(g)) - 1.0));
    EXPECT_LT(std::abs(pt.c_data / c_pred - 1.0), 5e-4) << f << " Hz: C_data " << pt.c_data;
    EXPECT_LT(std::abs(pt.beta_data / beta_pred - 1.0), 5e-4)
        << f << " Hz: beta_data " << pt.beta_data;
  }
  std::printf(
      "  [ZOH model] worst |C_data/pred - 1| = %.2e, |beta_data/pred - 1| = %.2e; raw eq. (18) "
      "gain error up to %.2f %%\n",
      worst_c, worst_beta, 100.0 * worst_raw_gain);
  const VirtualOmni omni(p);
  const LinearPlant lin = linear_plant(omni);
  EXPECT_LT(worst_raw_gain, 1.05 * lin.bt * 2.0 * kT / (2.0 * lin.c));
  EXPECT_GT(worst_raw_gain, 0.5 * lin.bt * 2.0 * kT / (2.0 * lin.c));
}

TEST(VirtualOmni, StepMatchesExactSampledDataAndContinuousSolutions) {
  // Square wave ±A from θ(0) = −A (eq. (47)), first half period (2 s).
  VirtualOmniParams p = linear_params();
  p.initial_theta_rad = -kAr;
  VirtualOmni omni(p);
  const LinearPlant lin = linear_plant(omni);
  Controller ctl;
  const SquareReference ref(kAr, 0.25);
  const RunData d = run_closed_loop(omni, ctl, ref, 1.999);

  // (1) Exact sampled-data recursion.
  Eigen::Matrix2d ad;
  Eigen::Vector2d bd;
  zoh(lin.c, lin.bt, kT, ad, bd);
  Eigen::Vector2d x(-kAr, 0.0);
  double worst_exact = 0.0;
  // (2) Continuous θ̈ + Cθ̇ + βθ = βA: θ = A − 2A e^{−σt}(cos ω_d t + (σ/ω_d) sin ω_d t).
  const double beta = lin.bt * ctl.kp, sigma = lin.c / 2.0, wd = std::sqrt(beta - sigma * sigma);
  double worst_cont = 0.0, max_speed = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double t = d.t[k];
    worst_exact = std::max(worst_exact, std::abs(d.theta[k] - x(0)));
    const double v = ctl.kp * (kAr - x(0));
    EXPECT_NEAR(d.v[k], v, 1e-9);
    x = ad * x + bd * v;
    const double cont =
        kAr - 2.0 * kAr * std::exp(-sigma * t) * (std::cos(wd * t) + sigma / wd * std::sin(wd * t));
    const double speed = 2.0 * kAr * std::exp(-sigma * t) * (beta / wd) * std::sin(wd * t);
    worst_cont = std::max(worst_cont, std::abs(d.theta[k] - cont));
    max_speed = std::max(max_speed, std::abs(speed));
  }
  EXPECT_LT(worst_exact, 1e-11);
  // The digital loop lags the continuous one by about T/2 and is slightly less damped
  // (C − βT/2): the difference is of order max|θ̇|·T/2 and grows slowly with the oscillation.
  std::printf(
      "  [step] max |sim - exact sampled| = %.2e rad, max |sim - continuous| = %.2e rad "
      "(max|theta'| T/2 = %.2e)\n",
      worst_exact, worst_cont, max_speed * kT / 2.0);
  EXPECT_LT(worst_cont, 2.0 * max_speed * kT);
}

TEST(VirtualOmni, ExactSegmentsAreTheSampledDataSolution) {
  // With exact_constant_segments and a constant torque (offset d0), each tick is the ZOH map
  // x_{k+1} = Ad x_k + Bd (v_k + d0) itself: the step response matches it to rounding, about 100×
  // closer than RK4's 1e-11 bound above.
  VirtualOmniParams p = linear_params();
  p.initial_theta_rad = -kAr;
  p.effects.offset_v = 0.01;
  p.exact_constant_segments = true;
  VirtualOmni omni(p);
  const LinearPlant lin = linear_plant(omni);
  Controller ctl;
  const SquareReference ref(kAr, 0.25);
  const RunData d = run_closed_loop(omni, ctl, ref, 1.999);
  Eigen::Matrix2d ad;
  Eigen::Vector2d bd;
  zoh(lin.c, lin.bt, kT, ad, bd);
  Eigen::Vector2d x(-kAr, 0.0);
  double worst = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    worst = std::max(worst, std::abs(d.theta[k] - x(0)));
    x = ad * x + bd * (ctl.kp * (kAr - x(0)) + 0.01);
  }
  EXPECT_LT(worst, 1e-13) << "worst |theta - exact sampled| = " << worst;
  EXPECT_GT(std::abs(x(0) - kAr), 0.004);  // the offset shows: e = d0/kp = 0.005 rad at rest
}

TEST(VirtualOmni, ExactSegmentsAgreeWithRk4AndStateDependentTorquesKeepRk4) {
  // The paper's α-model (C, β̃ change every tick), a fractional delay (two segments per tick), an
  // offset and a known disturbance: the exact segments and RK4 at 4 substeps give the same run
  // to RK4's error. With Coulomb friction (n depends on θ̇) the flag changes nothing, bit for bit.
  auto run = [](bool exact, double coulomb_v) {
    VirtualOmniParams p;
    p.effects.offset_v = -0.006;
    p.effects.delay_s = 2.5e-3;
    p.effects.coulomb_v = coulomb_v;
    p.exact_constant_segments = exact;
    VirtualOmni omni(p);
    ClosedLoopOptions opt;
    opt.disturbance_v = [](double t) { return t > 0.5 && t < 0.6 ? 0.02 : 0.0; };
    return run_closed_loop(omni, Controller{}, SineReference(kAr, 3.0), 2.0, opt);
  };
  const RunData rk4 = run(false, 0.0), exact = run(true, 0.0);
  double worst = 0.0, largest = 0.0;
  for (std::size_t k = 0; k < rk4.size(); ++k) {
    worst = std::max(worst, std::abs(rk4.theta[k] - exact.theta[k]));
    largest = std::max(largest, std::abs(rk4.theta[k]));
  }
  EXPECT_LT(worst, 1e-11) << "worst |exact - rk4| = " << worst;
  EXPECT_GT(largest, 0.03);
  const RunData rk4_c = run(false, 0.004), exact_c = run(true, 0.004);
  EXPECT_EQ(rk4_c.theta, exact_c.theta);
}

TEST(VirtualOmni, ModelSimulationSubstepsAreAccurateForSmoothTorquesAndAsTheGeneratorForFriction) {
  // The paper's α-model at the default pose: C ≤ ~30 1/s, so without a velocity term one RK4 step
  // per tick has h·λ ≈ 0.03 ≤ 0.25.
  VirtualOmniParams p;
  EXPECT_EQ(model_simulation_substeps(p), 1);
  p.effects.gravity_v = 0.3;  // √(β̃·g) ≈ 8 1/s
  p.effects.cogging_v = 0.01;
  EXPECT_EQ(model_simulation_substeps(p), 1);
  p.effects.gravity_v = 2e4;  // a spring of √(229·2e4) ≈ 2100 1/s: h·λ ≈ 2.1 at one step
  EXPECT_EQ(model_simulation_substeps(p), 16);
  // Friction: the first stable of 4, 16, …, as the generator's plant (4 for the sweep's Coulomb).
  VirtualOmniParams f;
  f.effects.coulomb_v = 0.004;
  EXPECT_EQ(model_simulation_substeps(f), 4);
  f.effects.coulomb_smoothing_rad_s = 1e-4;  // 10× stiffer: 4 steps are unstable
  EXPECT_EQ(model_simulation_substeps(f), 16);
  f.substeps = 16;
  EXPECT_NO_THROW(VirtualOmni{f});
  f.effects.coulomb_smoothing_rad_s = 1e-9;  // too stiff for 1000 steps
  EXPECT_EQ(model_simulation_substeps(f), 0);
  // And one step is accurate where it is chosen: against 64 steps, a sine run with gravity.
  auto run = [](int substeps) {
    VirtualOmniParams q;
    q.effects.gravity_v = 0.3;
    q.effects.gravity_theta0_rad = 0.2;
    q.substeps = substeps;
    VirtualOmni omni(q);
    return run_closed_loop(omni, Controller{}, SineReference(kAr, 5.0), 2.0);
  };
  const RunData one = run(1), many = run(64);
  double worst = 0.0;
  for (std::size_t k = 0; k < one.size(); ++k)
    worst = std::max(worst, std::abs(one.theta[k] - many.theta[k]));
  EXPECT_LT(worst, 1e-9) << "worst |1 step - 64 steps| = " << worst;
}

// --- (b) reproducibility
// ---------------------------------------------------------------------------

VirtualOmniParams noisy_params(std::uint64_t seed) {
  VirtualOmniParams p;  // the paper's α-model
  p.effects.coulomb_v = 0.004;
  p.measurement.quantisation_rad = 1.5e-4;
  p.measurement.noise_std_rad = 5e-5;
  p.measurement.seed = seed;
  return p;
}

TEST(VirtualOmni, SameSeedIsBitIdenticalAndAnotherSeedDiffers) {
  const SineReference ref(kAr, 3.0);
  Controller ctl;
  VirtualOmni a(noisy_params(42)), b(noisy_params(42)), c(noisy_params(43));
  const RunData da = run_closed_loop(a, ctl, ref, 2.0);
  const RunData db = run_closed_loop(b, ctl, ref, 2.0);
  const RunData dc = run_closed_loop(c, ctl, ref, 2.0);
  EXPECT_EQ(da.theta, db.theta);  // exact equality, element by element
  EXPECT_EQ(da.v, db.v);
  EXPECT_NE(da.theta, dc.theta);
  std::size_t differing = 0;
  for (std::size_t k = 0; k < da.size(); ++k) differing += da.theta[k] != dc.theta[k];
  EXPECT_GT(differing, da.size() / 4);
  // reset() restarts everything, including the noise stream.
  a.reset();
  const RunData again = run_closed_loop(a, ctl, ref, 2.0);
  EXPECT_EQ(again.theta, da.theta);
  EXPECT_EQ(again.v, da.v);
}

// --- (c) physical signatures of the effects ------------------------------------------------------

TEST(VirtualOmniEffects, OffsetTorqueGivesSteadyStateErrorOfD0OverKp) {
  // θ̈ + Cθ̇ = β̃(kp(r − θ) + d0) settles at θ = r + d0/kp.
  VirtualOmniParams p;  // paper α-model: the equilibrium does not depend on C or β̃
  p.effects.offset_v = 0.02;
  VirtualOmni omni(p);
  Controller ctl;
  const ConstantReference ref(0.03);
  const RunData d = run_closed_loop(omni, ctl, ref, 6.0);
  EXPECT_NEAR(d.theta.back(), 0.03 + 0.02 / ctl.kp, 1e-7);
  EXPECT_NEAR(d.r.back() - d.theta.back(), -0.01, 1e-7);
}

TEST(VirtualOmniEffects, GravityEquilibriumBalancesKpTimesError) {
  // Equilibrium of kp(r − θ) − g sin(θ + θ0) = 0.
  VirtualOmniParams p;
  p.effects.gravity_v = 0.1;
  p.effects.gravity_theta0_rad = 0.3;
  VirtualOmni omni(p);
  Controller ctl;
  const ConstantReference ref(0.05);
  const RunData d = run_closed_loop(omni, ctl, ref, 6.0);
  const double th = d.theta.back(), e = 0.05 - th;
  EXPECT_NEAR(ctl.kp * e, 0.1 * std::sin(th + 0.3), 1e-8);
  EXPECT_GT(e, 0.01);  // gravity pulls θ well short of r
  EXPECT_NEAR(omni.disturbance(), -0.1 * std::sin(omni.theta() + 0.3), 1e-15);
}

TEST(VirtualOmniEffects, SaturationBoundsTheAppliedCommand) {
  VirtualOmniParams p = linear_params();
  p.initial_theta_rad = -kAr;
  p.effects.saturation_v = 0.1;  // the step asks for kp·2A = 0.28 V
  VirtualOmni omni(p);
  Controller ctl;
  const SquareReference ref(kAr, 0.25);
  double peak = 0.0;
  std::size_t saturated = 0;
  for (int k = 0; k < 2000; ++k) {
    const double v = ctl.kp * (ref.at(k * kT).r - omni.theta_measured());
    (void)omni.step(v);
    EXPECT_LE(omni.command_effective_peak(), 0.1);
    peak = std::max(peak, omni.command_effective_peak());
    saturated += std::abs(v) > 0.1;
  }
  EXPECT_EQ(peak, 0.1);
  EXPECT_GT(saturated, 10u);
  // Saturated, the start is the open-loop ramp of v = v_max: θ(t) = −A + (β̃v/C)(t − (1−e^{−Ct})/C).
  VirtualOmni fresh(p);
  const LinearPlant lin = linear_plant(fresh);
  for (int k = 0; k < 20; ++k) (void)fresh.step(0.28);
  const double t = 20 * kT;
  EXPECT_NEAR(fresh.theta(), -kAr + lin.bt * 0.1 / lin.c * (t - (1 - std::exp(-lin.c * t)) / lin.c),
              1e-12);
}

TEST(VirtualOmniEffects, DeadzoneStopsSmallCommandsAndShiftsLargeOnes) {
  VirtualOmniParams p = linear_params();
  p.effects.deadzone_v = 0.02;
  VirtualOmni omni(p);
  const std::vector<double> still = sample_plant(omni, 1000, 0.9 * 0.02);
  for (double th : still) EXPECT_EQ(th, 0.0);
  EXPECT_EQ(omni.command_effective(), 0.0);
  // |v| > d: the plant sees v − d (and −(|v| − d) for negative v).
  VirtualOmni moving(p);
  const LinearPlant lin = linear_plant(moving);
  const std::vector<double> th = sample_plant(moving, 1000, -0.05);
  const double t = 1.0, ve = -0.03;
  EXPECT_NEAR(th.back(), lin.bt * ve / lin.c * (t - (1 - std::exp(-lin.c * t)) / lin.c), 1e-11);
  EXPECT_DOUBLE_EQ(moving.command_effective(), ve);
}

/// Phase [rad] of the steady-state response θ to an open-loop sine command A sin ωt.
double open_loop_phase(const VirtualOmniParams& p, double f) {
  VirtualOmni omni(p);
  std::vector<double> t, th;
  for (int k = 0; k < 5000; ++k) {
    const double tk = k * kT;
    if (tk >= 3.0) {  // after 3 s e^{−Ct} < 1e-8
      t.push_back(tk);
      th.push_back(omni.theta());
    }
    (void)omni.step(0.05 * std::sin(kTwoPi * f * tk));
  }
  const SineFit fit = fit_sine(t, th, kTwoPi * f, true);  // open loop: θ drifts to an offset
  return std::atan2(fit.a1, fit.a2);
}

TEST(VirtualOmniEffects, DelayAddsPhaseLagOmegaTau) {
  // v_eff(t) = v(t − τ) shifts the held command in time, so the steady-state response lags by
  // exactly ωτ more, for whole and fractional ticks.
  const VirtualOmniParams base = linear_params();
  for (double tau : {0.005, 0.0025, 0.0123}) {
    VirtualOmniParams p = base;
    p.effects.delay_s = tau;
    for (double f : {2.0, 5.0}) {
      const double lag = std::remainder(open_loop_phase(base, f) - open_loop_phase(p, f), kTwoPi);
      EXPECT_NEAR(lag, kTwoPi * f * tau, 1e-6) << "tau " << tau << " s, " << f << " Hz";
    }
  }
}

TEST(VirtualOmniEffects, CoggingMakesDetentsPeriodicInTheta) {
  // n = a sin(2πθ/p + φ): with no command the joint settles in a detent where n = 0 and n falls
  // with θ: 2πθ*/p + φ = π (mod 2π). Detents repeat every p.
  VirtualOmniParams p;  // paper α-model
  p.effects.cogging_v = 0.01;
  p.effects.cogging_period_rad = 0.02;
  p.effects.cogging_phase_rad = 0.4;
  const double period = 0.02, first = (kPi - 0.4) / kTwoPi * period;
  std::vector<double> finals;
  for (double start : {0.0, 0.006, 0.013, 0.021, 0.033}) {
    p.initial_theta_rad = start;
    VirtualOmni omni(p);
    for (int k = 0; k < 4000; ++k) (void)omni.step(0.0);
    const double cycles = (omni.theta() - first) / period;
    EXPECT_NEAR(cycles, std::round(cycles), 1e-6) << "from " << start;
    EXPECT_NEAR(omni.theta_dot(), 0.0, 1e-6);
    finals.push_back(omni.theta());
  }
  EXPECT_NEAR(finals.back() - finals.front(), period, 1e-7);  // two detents, one period apart
  VirtualOmni omni(p);
  EXPECT_NEAR(omni.effect_torque(0.0123, 0.0), omni.effect_torque(0.0123 + 3 * period, 0.0), 1e-15);
}

TEST(VirtualOmniEffects, CoulombFrictionSticksTheStepWithinFcOverKp) {
  // A P-controlled step with Coulomb friction sticks where |kp e| ≤ Fc (here just past the target,
  // after the overshoot), instead of settling on it; the tanh model then creeps on slowly, with
  // time constant ≈ C_eff/β = (β̃Fc/ε)/(β̃kp) = 5 s.
  VirtualOmniParams p;  // paper α-model
  p.initial_theta_rad = -kAr;
  VirtualOmniParams with = p;
  with.effects.coulomb_v = 0.01;
  with.effects.coulomb_smoothing_rad_s = 1e-3;
  Controller ctl;
  const SquareReference ref(kAr, 0.25);
  VirtualOmni a(p), b(with);
  const RunData free_run = run_closed_loop(a, ctl, ref, 1.9);
  const RunData stuck = run_closed_loop(b, ctl, ref, 1.9);
  const double e_free = kAr - free_run.theta.back(), e_stuck = kAr - stuck.theta.back();
  std::printf(
      "  [coulomb] final error without %.2e rad, with Fc = 0.01 V: %.2e rad (band Fc/kp = %.3f)\n",
      e_free, e_stuck, 0.01 / ctl.kp);
  EXPECT_LT(std::abs(e_free), 1e-6);
  EXPECT_LE(std::abs(e_stuck), 0.01 / ctl.kp);
  EXPECT_GT(std::abs(e_stuck), 0.1 * 0.01 / ctl.kp);
  EXPECT_LT(std::abs(b.theta_dot()), 2e-3);  // nearly stuck
}

// --- (d) measurement
// ------------------------------------------------------------------------------

TEST(VirtualOmniMeasurement, QuantisedMeasurementIsAMultipleOfTheStep) {
  VirtualOmniParams p = noisy_params(7);
  VirtualOmni omni(p);
  Controller ctl;
  const SineReference ref(kAr, 3.0);
  const RunData d = run_closed_loop(omni, ctl, ref, 2.0, truth_columns());
  const std::vector<double>& truth = d.extra_columns.at("theta_true");
  std::size_t distinct_counts = 0;
  double prev = 1e9, sum_sq = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) {
    const double counts = d.theta[k] / 1.5e-4;
    EXPECT_NEAR(counts, std::round(counts), 1e-9);
    distinct_counts += d.theta[k] != prev;
    prev = d.theta[k];
    sum_sq += (d.theta[k] - truth[k]) * (d.theta[k] - truth[k]);
  }
  EXPECT_GT(distinct_counts, 100u);
  // Error = noise + quantisation: variance σ² + q²/12 (q²/12 for the dithered rounding).
  const double rms = std::sqrt(sum_sq / static_cast<double>(d.size()));
  const double expected = std::sqrt(5e-5 * 5e-5 + 1.5e-4 * 1.5e-4 / 12.0);
  EXPECT_NEAR(rms, expected, 0.05 * expected);
}

TEST(VirtualOmniMeasurement, NoiseHasTheRequestedStandardDeviation) {
  VirtualOmniParams p = linear_params();
  p.measurement.noise_std_rad = 2e-4;
  p.measurement.seed = 123;
  VirtualOmni omni(p);
  double sum = 0.0, sum_sq = 0.0;
  const int n = 20000;
  for (int k = 0; k < n; ++k) {
    const double e = omni.step(0.0) - omni.theta();
    sum += e;
    sum_sq += e * e;
  }
  const double mean = sum / n, sd = std::sqrt(sum_sq / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 4.0 * 2e-4 / std::sqrt(n));
  EXPECT_NEAR(sd, 2e-4, 0.02 * 2e-4);
}

// --- α inside the plant
// ----------------------------------------------------------------------------

TEST(VirtualOmni, PlantAlphaIsTheFilteredCommandEnergy) {
  // An open-loop sine command A sin ωt: the plant's α̂ settles at |H(ω)|²·A²ω² and C, β̃ follow the
  // α-model there.
  const VirtualOmniParams p;  // paper α-model
  VirtualOmni omni(p);
  const double a = 0.2, f = 5.0, w = kTwoPi * f;
  double lo = 1e9, hi = -1e9;
  for (int k = 0; k < 3000; ++k) {
    (void)omni.step(a * std::sin(w * k * kT));
    if (k > 1000) {
      lo = std::min(lo, omni.alpha());
      hi = std::max(hi, omni.alpha());
    }
  }
  const rt::AlphaEstimator est(p.alpha_filter);
  const double expected = est.alpha_gain(f) * a * a * w * w;
  EXPECT_NEAR(lo, expected, 2e-3 * expected);
  EXPECT_NEAR(hi, expected, 2e-3 * expected);
  EXPECT_GT(est.alpha_gain(f), 0.995);
  EXPECT_DOUBLE_EQ(omni.damping(), p.alpha_model.damping(omni.alpha(), omni.inertia()));
  EXPECT_DOUBLE_EQ(omni.beta_tilde(), p.alpha_model.beta_tilde(omni.alpha(), omni.inertia()));
}

// --- the digital controller
// -------------------------------------------------------------------------

TEST(VirtualOmni, RecordedCommandIsTheDigitalPidOfTheRecordedColumns) {
  const VirtualOmniParams p = noisy_params(5);
  for (DerivativeOn on : {DerivativeOn::kError, DerivativeOn::kMeasurement}) {
    Controller ctl;
    ctl.kp = 2.0;
    ctl.ki = 3.0;
    ctl.kd = 0.01;
    ctl.derivative_on = on;
    ctl.v_limit = 0.05;
    VirtualOmni omni(p);
    const SineReference ref(kAr, 2.0);
    const RunData d = run_closed_loop(omni, ctl, ref, 1.0);
    ASSERT_EQ(d.size(), 1001u);
    double integral = 0.0;
    std::size_t clipped = 0;
    for (std::size_t k = 0; k < d.size(); ++k) {
      EXPECT_DOUBLE_EQ(d.t[k], static_cast<double>(k) * kT);
      EXPECT_DOUBLE_EQ(d.r[k], ref.at(d.t[k]).r);
      const double e = d.r[k] - d.theta[k];
      integral += kT * e;
      double der = 0.0;
      if (k > 0) {
        der = on == DerivativeOn::kError ? (e - (d.r[k - 1] - d.theta[k - 1])) / kT
                                         : -(d.theta[k] - d.theta[k - 1]) / kT;
      }
      const double raw = ctl.kp * e + ctl.ki * integral + ctl.kd * der;
      clipped += std::abs(raw) > ctl.v_limit;
      EXPECT_DOUBLE_EQ(d.v[k], std::clamp(raw, -0.05, 0.05)) << k;
    }
    EXPECT_GT(clipped, 10u);  // the limit is in force part of the time
  }
}

TEST(VirtualOmni, DisturbanceColumnIsRecordedAndActsLikeAnOffset) {
  VirtualOmni omni(linear_params());
  Controller ctl;
  ClosedLoopOptions opt;
  opt.disturbance_v = [](double t) { return t < 1.0 ? 0.0 : 0.02; };
  const RunData d = run_closed_loop(omni, ctl, ConstantReference(0.0), 6.0, opt);
  const std::vector<double>& dist = d.extra_columns.at("disturbance_v");
  EXPECT_EQ(dist.front(), 0.0);
  EXPECT_EQ(dist.back(), 0.02);
  EXPECT_NEAR(d.theta.back(), 0.02 / ctl.kp, 1e-7);
}

TEST(VirtualOmni, TheDiscoveredMemoryTermsAreATorqueOfTheTrueStatesHistoryHeldOverEachTick) {
  // The plant with the memory terms equals the plant without them driven by that torque as a
  // known disturbance, computed here along its true states (ground truth, bit for bit).
  VirtualOmniParams p = linear_params();
  p.effects.discovered_lag_sign_v = -0.01;
  p.effects.discovered_dahl_v = -0.005;
  p.effects.discovered_lag_s = 0.02;
  p.effects.discovered_dahl_rad = 1e-3;
  p.effects.discovered_lag_smoothing_rad_s = 0.02;
  VirtualOmni with(p);
  VirtualOmniParams q = p;
  q.effects.discovered_lag_sign_v = q.effects.discovered_dahl_v = 0.0;
  VirtualOmni without(q);
  const Effects& e = p.effects;
  const double lambda = std::exp(-kT / 0.02);
  double f = without.theta_dot(), z = 0.0, theta_prev = without.theta();
  double largest = 0.0;
  for (int k = 0; k < 3000; ++k) {
    const double v = 0.2 * std::sin(kTwoPi * 1.5 * k * kT);
    const double th = without.theta(), om = without.theta_dot();
    f = om + (f - om) * lambda;
    const double d = th - theta_prev;
    if (d != 0.0) {
      const double s = d > 0.0 ? 1.0 : -1.0;
      z = s - (s - z) * std::exp(-std::abs(d) / 1e-3);
    }
    theta_prev = th;
    const double n = e.discovered_lag_sign_v * std::tanh(f / 0.02) + e.discovered_dahl_v * z;
    largest = std::max(largest, std::abs(n));
    KnownInputs in;
    in.disturbance_v = n;
    without.step(v, in);
    with.step(v);
    ASSERT_EQ(with.theta(), without.theta()) << k;
  }
  EXPECT_GT(largest, 0.012);  // the terms acted
}

// --- (e) real-time: no allocation
// -------------------------------------------------------------------

TEST(VirtualOmni, StepResetAndSetPoseAllocateNothing) {
  VirtualOmniParams p = noisy_params(9);
  p.effects.delay_s = 0.0042;
  p.effects.gravity_v = 0.01;
  p.effects.cogging_v = 0.002;
  p.effects.offset_v = 0.001;
  p.effects.saturation_v = 0.2;
  p.effects.deadzone_v = 0.001;
  p.effects.discovered_lag_sign_v = -0.002;  // and the discovered term's memory terms
  p.effects.discovered_dahl_v = -0.001;
  VirtualOmni omni(p);
  double sink = 0.0;
  const long before = test::allocation_count();
  for (int k = 0; k < 20000; ++k) sink += omni.step(0.1 * std::sin(0.01 * k), 0.001);
  omni.reset();
  sink += static_cast<double>(omni.set_pose(40.0, 80.0));
  sink += omni.alpha() + omni.damping() + omni.beta_tilde() + omni.disturbance();
  const long after = test::allocation_count();
  EXPECT_EQ(after - before, 0) << "allocations in step/reset/set_pose";
  EXPECT_TRUE(std::isfinite(sink));
}

// --- pose
// --------------------------------------------------------------------------------------------

TEST(VirtualOmni, PoseSetsTheInertiaOfEq6) {
  VirtualOmni omni(VirtualOmniParams{});
  EXPECT_NEAR(1.0 / omni.inertia(), 229.04, 0.03);  // Table 5, 65°/90° modelled β̃_linear
  ASSERT_TRUE(omni.set_pose(21.54, 69.54));
  EXPECT_NEAR(1.0 / omni.inertia(), 222.41, 0.03);  // Table 5, 25°/70°
  const double before = omni.inertia();
  EXPECT_FALSE(omni.set_pose(std::nan(""), 10.0));
  EXPECT_EQ(omni.inertia(), before);
}

// --- (g) validation names the field
// ------------------------------------------------------------------

TEST(VirtualOmni, InvalidParamsThrowNamingTheField) {
  struct Case {
    std::string field;
    std::function<void(VirtualOmniParams&)> spoil;
  };
  const double nan = std::nan("");
  const Case cases[] = {
      {"tick_period_s", [](VirtualOmniParams& p) { p.tick_period_s = 0.0; }},
      {"substeps", [](VirtualOmniParams& p) { p.substeps = 0; }},
      {"alpha_filter.sample_period_s",
       [](VirtualOmniParams& p) { p.alpha_filter.sample_period_s = 2e-3; }},
      {"alpha_filter.cutoff_hz", [](VirtualOmniParams& p) { p.alpha_filter.cutoff_hz = 300.0; }},
      {"alpha_model", [](VirtualOmniParams& p) { p.alpha_model.c_n1[1] = -1.0; }},
      {"gamma1_deg", [nan](VirtualOmniParams& p) { p.gamma1_deg = nan; }},
      {"inertia", [](VirtualOmniParams& p) { p.inertia.i_base = -1.0; }},
      {"inertia.i2", [nan](VirtualOmniParams& p) { p.inertia.i2 = nan; }},
      {"initial_theta_rad", [nan](VirtualOmniParams& p) { p.initial_theta_rad = nan; }},
      {"effects.coulomb_v", [](VirtualOmniParams& p) { p.effects.coulomb_v = -0.1; }},
      {"effects.coulomb_smoothing_rad_s",
       [](VirtualOmniParams& p) {
         p.effects.coulomb_v = 0.01;
         p.effects.coulomb_smoothing_rad_s = 0.0;
       }},
      {"effects.coulomb_smoothing_rad_s",  // too sharp for 4 RK4 substeps
       [](VirtualOmniParams& p) {
         p.effects.coulomb_v = 0.05;
         p.effects.coulomb_smoothing_rad_s = 1e-5;
       }},
      {"effects.offset_v", [nan](VirtualOmniParams& p) { p.effects.offset_v = nan; }},
      {"effects.gravity_v",
       [](VirtualOmniParams& p) { p.effects.gravity_v = std::numeric_limits<double>::infinity(); }},
      {"effects.cogging_period_rad",
       [](VirtualOmniParams& p) {
         p.effects.cogging_v = 0.01;
         p.effects.cogging_period_rad = 0.0;
       }},
      {"effects.delay_s", [](VirtualOmniParams& p) { p.effects.delay_s = -1e-3; }},
      {"effects.delay_s", [](VirtualOmniParams& p) { p.effects.delay_s = 2.0; }},
      {"effects.saturation_v", [](VirtualOmniParams& p) { p.effects.saturation_v = 0.0; }},
      {"effects.deadzone_v", [](VirtualOmniParams& p) { p.effects.deadzone_v = -0.01; }},
      {"measurement.quantisation_rad",
       [](VirtualOmniParams& p) { p.measurement.quantisation_rad = -1; }},
      {"measurement.noise_std_rad",
       [nan](VirtualOmniParams& p) { p.measurement.noise_std_rad = nan; }},
  };
  for (const Case& c : cases) {
    VirtualOmniParams p;
    c.spoil(p);
    try {
      VirtualOmni omni(p);
      ADD_FAILURE() << "no error for " << c.field;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), c.field) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
  // More substeps cure the stiff Coulomb case.
  VirtualOmniParams p;
  p.effects.coulomb_v = 0.05;
  p.effects.coulomb_smoothing_rad_s = 1e-5;
  try {
    p.validate();
  } catch (const Error& e) {
    std::printf("  [validation] %s\n", e.what());
  }
  p.substeps = 1000;
  EXPECT_NO_THROW(p.validate());
  Controller ctl;
  VirtualOmni omni(linear_params());
  EXPECT_THROW(run_closed_loop(omni, ctl, ConstantReference(0.0), 0.0), Error);
}

}  // namespace
}  // namespace alphainv
