#include "alphainv/identify/time_domain_fit.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "alphainv/simulate/virtual_omni.hpp"
#include "support/error_of.hpp"

namespace alphainv {
namespace {

/// A multisine reference (no single frequency: the sine-sweep identification cannot use it).
class MultiSine final : public Reference {
 public:
  ReferenceSample at(double t) const override {
    ReferenceSample s;
    const double a[3] = {0.03, 0.02, 0.015}, f[3] = {0.7, 2.3, 5.1};
    for (int i = 0; i < 3; ++i) {
      const double w = 2 * M_PI * f[i];
      s.r += a[i] * std::sin(w * t);
      s.r_dot += a[i] * w * std::cos(w * t);
      s.r_ddot -= a[i] * w * w * std::sin(w * t);
    }
    return s;
  }
  void discontinuities(double, double, std::vector<double>&) const override {}
};

std::vector<RunData> plant_runs(const VirtualOmniParams& p, const Controller& ctl) {
  std::vector<RunData> runs;
  const SquareReference sq(0.06, 0.4);
  const MultiSine ms;
  for (const Reference* ref : {static_cast<const Reference*>(&sq), static_cast<const Reference*>(&ms)}) {
    VirtualOmni omni(p);
    runs.push_back(run_closed_loop(omni, ctl, *ref, 4.0));
  }
  return runs;
}

/// The linear time-domain fit of `runs` as the 1 kHz digital loop, checked against the truth C,
/// β̃ within 2 %.
TimeDomainLinearFit digital_linear_fit(const std::vector<TimeDomainRun>& runs, double c, double bt) {
  TimeDomainFitOptions o;
  o.simulation.loop_period_s = 1e-3;
  const TimeDomainLinearFit fit = fit_linear_time_domain(runs, o);
  EXPECT_NEAR(fit.c_linear, c, 0.02 * c);
  EXPECT_NEAR(fit.beta_tilde_linear, bt, 0.02 * bt);
  return fit;
}

/// The runs as the time-domain fits take them, all under `ctl`.
std::vector<TimeDomainRun> time_domain_runs(const std::vector<RunData>& runs, const Controller& ctl) {
  std::vector<TimeDomainRun> tr;
  for (const auto& r : runs) tr.push_back({&r, ctl});
  return tr;
}

TEST(LocalQuadraticDerivatives, ExactOnAQuadraticWithIrregularSampling) {
  std::vector<double> t, y;
  double tt = 0.0;
  for (int k = 0; k < 200; ++k) {
    tt += 0.004 + 0.002 * std::sin(1.7 * k);  // irregular, 2-6 ms
    t.push_back(tt);
    y.push_back(1.0 - 2.0 * tt + 3.0 * tt * tt);
  }
  std::vector<double> dy, ddy;
  local_quadratic_derivatives(t, y, 0.01, dy, ddy);
  for (std::size_t k = 0; k < t.size(); ++k) {
    EXPECT_NEAR(dy[k], -2.0 + 6.0 * t[k], 1e-7);
    EXPECT_NEAR(ddy[k], 6.0, 1e-5);
  }
  // α of v = A sin ωt is A²ω² (eq. (36)), away from the ends.
  std::vector<double> ts, v;
  for (int k = 0; k < 3000; ++k) {
    ts.push_back(1e-3 * k);
    v.push_back(0.2 * std::sin(2 * M_PI * 3.0 * ts.back()));
  }
  const auto a = alpha_of_command(ts, v, 0.005);
  const double expect = std::pow(0.2 * 2 * M_PI * 3.0, 2);
  for (std::size_t k = 100; k + 100 < a.size(); k += 50) EXPECT_NEAR(a[k], expect, 0.01 * expect);
}

TEST(TimeDomainFit, LinearModelFromSquareAndMultisineRunsOfTheDigitalPlant) {
  VirtualOmniParams p;
  const double i = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
  const double c = 9.0, bt = 180.0;  // not the paper's values
  p.alpha_model = constant_alpha_model(1.0 / (c * i), 1.0 / (bt * i));
  p.measurement.quantisation_rad = 1.5e-4;
  p.measurement.noise_std_rad = 5e-5;
  p.measurement.seed = 11;
  Controller ctl;
  ctl.kp = 3.0;
  const auto runs = plant_runs(p, ctl);
  const std::vector<TimeDomainRun> tr = time_domain_runs(runs, ctl);
  const TimeDomainLinearFit fit = digital_linear_fit(tr, c, bt);
  ASSERT_TRUE(fit.ok) << fit.message;
  // The equation-error start is close but biased (the hold's delay, noisy derivatives).
  EXPECT_NEAR(fit.beta_tilde_equation_error, bt, 0.3 * bt);
  EXPECT_LT(fit.rms, 2e-4);
  EXPECT_TRUE(fit.usable());
  EXPECT_EQ(fit.brief_report(),
            "time-domain linear fit: usable, C = 8.999 ± 0.0013 1/s, β̃ = 179.9 ± 0.01, RMS of "
            "θ − θ_sim 0.0001257");
  const std::string full = fit.full_report();
  EXPECT_EQ(full, fit.brief_report() + "\n  equation-error start: C = 8.532 1/s, β̃ = 175.4\n  " +
                      fit.message + "\n");
  EXPECT_EQ(fit.message.rfind("Ceres Solver Report: Iterations: ", 0), 0u) << fit.message;
}

TEST(TimeDomainFit, AlphaModelFromTimeDomainRunsMatchesTheTruthAlongTheData) {
  VirtualOmniParams p;  // the paper's α-model at its 65°/90° pose
  p.measurement.quantisation_rad = 1.5e-4;
  p.measurement.seed = 3;
  Controller ctl;
  ctl.kp = 2.0;
  const auto runs = plant_runs(p, ctl);
  const std::vector<TimeDomainRun> tr = time_domain_runs(runs, ctl);
  TimeDomainFitOptions o;
  o.simulation.loop_period_s = 1e-3;
  const TimeDomainLinearFit lin = fit_linear_time_domain(tr, o);
  ASSERT_TRUE(lin.ok) << lin.message;
  const TimeDomainAlphaFit al = fit_alpha_time_domain(tr, lin, o);
  ASSERT_TRUE(al.ok) << al.message;
  EXPECT_LT(al.rms, 0.6 * lin.rms);  // the α-model explains what the linear one cannot
  // C(α) of the fit (I = 1) against the truth C(α, I) where the data has most of its α: the
  // median α of the commands and below.
  const double inertia = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
  const double a_mid = al.model.alpha[1];
  for (double a : {0.0, 0.5 * a_mid, a_mid}) {
    const double truth = p.alpha_model.damping(a, inertia);
    EXPECT_NEAR(al.model.damping(a, 1.0), truth, 0.15 * truth) << "alpha " << a;
  }
  // Identifiability from the SEs and correlations: C_0 (most data) is; every estimate has a
  // correlation with another in [0, 1].
  EXPECT_TRUE(al.c_identifiable[0]);
  for (std::size_t k = 0; k < al.model.n_breakpoints + 2; ++k) {
    EXPECT_GE(al.max_abs_correlation[k], 0.0) << k;
    EXPECT_LE(al.max_abs_correlation[k], 1.0 + 1e-12) << k;
  }
  EXPECT_TRUE(al.usable());
  EXPECT_EQ(al.brief_report(),
            "time-domain α fit: usable, N = 4 breakpoints up to α = 11.23 (the commands reach "
            "1114), RMS of θ − θ_sim 0.0006461");
  const std::string full = al.full_report();
  for (const char* line :
       {"  α_0 = 0: C_0 = 16.58 ± 0.084 1/s", "  α_3 = 11.23: C_3 = 9.218 ± 0.015 1/s",
        "  β̃_1 = 236.5 ± 0.19 at α = 11.23"}) {
    EXPECT_NE(full.find(std::string("\n") + line + "\n"), std::string::npos)
        << line << "\n" << full;
  }
}

/// An open-loop run of `p`: no controller, the plant driven by the recorded command v = a
/// multisine [V] held over each 1 ms tick (the form most identification benchmarks take).
RunData open_loop_run(const VirtualOmniParams& p, double duration_s) {
  VirtualOmni omni(p);
  const MultiSine ms;
  RunData d;
  for (int k = 0; k <= static_cast<int>(duration_s / 1e-3); ++k) {
    const double t = 1e-3 * k;
    d.t.push_back(t);
    d.r.push_back(0.0);
    d.theta.push_back(omni.theta_measured());
    d.v.push_back(0.5 * ms.at(t).r);
    (void)omni.step(d.v.back());
  }
  return d;
}

TEST(TimeDomainFit, AnOpenLoopRunIsFittedWithItsCommandAsTheInput) {
  VirtualOmniParams p;
  const double i = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
  const double c = 9.0, bt = 180.0;
  p.alpha_model = constant_alpha_model(1.0 / (c * i), 1.0 / (bt * i));
  p.measurement.noise_std_rad = 5e-5;
  p.measurement.seed = 4;
  const RunData run = open_loop_run(p, 4.0);
  const std::vector<TimeDomainRun> tr{{&run, kUnstatedController}};  // kp = ki = kd = 0
  const TimeDomainLinearFit fit = digital_linear_fit(tr, c, bt);
  ASSERT_TRUE(fit.ok) << fit.message;
  // Open loop θ integrates: the error of θ̇(0), estimated from 10 ms of noisy samples (about
  // σ/5 ms = 0.01 rad/s), stays as an offset of θ̇-error/C ≈ 1e-3 rad. Closed loop it would decay.
  EXPECT_LT(fit.rms, 2e-3);
}

TEST(TimeDomainFit, LowSampleRatesFitWithTheAlphaFilterCutOffFromTheData) {
  // A rig sampled (and controlled) at 40 Hz or 20 Hz: the α filter's 25 Hz default is above its
  // stability bound 0.25/T, so the digital loop runs it at 0.2/T (8 Hz, 4 Hz), as the plant does.
  for (double rate_hz : {40.0, 20.0}) {
    VirtualOmniParams p;
    const double i = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
    const double c = 9.0, bt = 180.0;
    p.alpha_model = constant_alpha_model(1.0 / (c * i), 1.0 / (bt * i));
    p.tick_period_s = p.alpha_filter.sample_period_s = 1.0 / rate_hz;
    p.alpha_filter.cutoff_hz = 0.2 * rate_hz;
    Controller ctl;
    ctl.kp = 1.0;
    const auto runs = plant_runs(p, ctl);
    const std::vector<TimeDomainRun> tr = time_domain_runs(runs, ctl);
    TimeDomainFitOptions o;
    o.simulation.loop_period_s = 1.0 / rate_hz;  // loop_alpha_cutoff_hz left at 25 Hz
    EXPECT_DOUBLE_EQ(loop_alpha_cutoff_hz(o.simulation), 0.2 * rate_hz);
    const TimeDomainLinearFit fit = fit_linear_time_domain(tr, o);
    ASSERT_TRUE(fit.ok) << rate_hz << " Hz: " << fit.message;
    EXPECT_NEAR(fit.c_linear, c, 0.01 * c) << rate_hz;
    EXPECT_NEAR(fit.beta_tilde_linear, bt, 0.01 * bt) << rate_hz;
    // Noise-free, the plant's own loop: what is left is θ̇(0) estimated from the first 4 samples
    // (100-200 ms) of runs that start at rest and accelerate (5e-4 rad at 40 Hz, 1.9e-3 at 20 Hz).
    EXPECT_LT(fit.rms, 3e-3) << rate_hz;
  }
}

TEST(TimeDomainFit, NoExcitationGivesAMessage) {
  RunData d;
  for (int k = 0; k < 500; ++k) {
    d.t.push_back(1e-3 * k);
    d.r.push_back(0.0);
    d.theta.push_back(0.0);
    d.v.push_back(0.0);
  }
  Controller ctl;
  const TimeDomainLinearFit fit = fit_linear_time_domain({{&d, ctl}});
  EXPECT_FALSE(fit.ok);
  EXPECT_NE(fit.message.find("excite"), std::string::npos) << fit.message;
  EXPECT_FALSE(fit.usable());
  EXPECT_EQ(fit.brief_report(), "time-domain linear fit: NOT usable: " + fit.message);
}

TEST(TimeDomainFit, InvalidOptionsAreNamedInTheResultNotThrown) {
  TimeDomainFitOptions o;
  EXPECT_NO_THROW(o.validate());
  o.smoothing_window_s = 0.0;
  EXPECT_EQ(test::error_of([&] { o.validate(); }).field(),
            "TimeDomainFitOptions::smoothing_window_s");
  RunData d;
  for (int k = 0; k < 500; ++k) {
    d.t.push_back(1e-3 * k);
    d.r.push_back(0.01 * std::sin(10.0 * d.t.back()));
    d.theta.push_back(0.0);
    d.v.push_back(0.0);
  }
  const std::vector<TimeDomainRun> runs = {{&d, Controller{}}};
  const TimeDomainLinearFit lin = fit_linear_time_domain(runs, o);
  EXPECT_FALSE(lin.usable());
  EXPECT_EQ(lin.message,
            "invalid options: 'TimeDomainFitOptions::smoothing_window_s': expected a finite number "
            "> 0, got 0");
  o = TimeDomainFitOptions{};
  o.n_breakpoints = 9;
  TimeDomainLinearFit start;
  start.ok = true;
  start.c_linear = 5.0;
  start.beta_tilde_linear = 200.0;
  const TimeDomainAlphaFit al = fit_alpha_time_domain(runs, start, o);
  EXPECT_FALSE(al.usable());
  EXPECT_EQ(al.brief_report(),
            "time-domain α fit: NOT usable: invalid options: "
            "'TimeDomainFitOptions::n_breakpoints': expected 2 to 8 breakpoints, got 9");
  o = TimeDomainFitOptions{};
  o.effects.coulomb_v = -0.1;
  EXPECT_NE(
      fit_linear_time_domain(runs, o).message.find("'TimeDomainFitOptions::effects.coulomb_v'"),
      std::string::npos);
}

}  // namespace
}  // namespace alphainv
