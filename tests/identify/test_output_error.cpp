#include "alphainv/identify/output_error.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv {
namespace {

/// Runs of the virtual plant (constant C, β̃ at its default pose, given effects and noise).
std::vector<RunData> plant_runs(const Effects& fx, double c, double bt, std::uint64_t seed) {
  VirtualOmniParams p;
  const double i = p.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
  p.alpha_model = constant_alpha_model(1.0 / (c * i), 1.0 / (bt * i));
  p.effects = fx;
  p.measurement.quantisation_rad = 1.5e-4;
  p.measurement.noise_std_rad = 5e-5;
  p.measurement.seed = seed;
  Controller ctl;
  ctl.kp = 2.0;
  std::vector<RunData> runs;
  const SquareReference sq(0.07, 0.5);
  const SineReference s1(0.05, 1.5), s2(0.07, 4.0);
  for (const Reference* ref : {static_cast<const Reference*>(&sq), static_cast<const Reference*>(&s1),
                               static_cast<const Reference*>(&s2)}) {
    VirtualOmni omni(p);
    runs.push_back(run_closed_loop(omni, ctl, *ref, 3.0));
  }
  return runs;
}

/// `n` samples at 1 kHz of a joint at rest under a constant reference of 0.01.
RunData resting_run(int n) {
  RunData d;
  for (int k = 0; k < n; ++k) {
    d.t.push_back(k * 1e-3);
    d.r.push_back(0.01);
    d.theta.push_back(0);
    d.v.push_back(0);
  }
  return d;
}

TEST(OutputError, RecoversLinearModelCoulombAndOffsetFromTheVirtualPlant) {
  Effects fx;
  fx.coulomb_v = 0.01;
  fx.offset_v = -0.004;
  const double c_true = 7.5, bt_true = 210.0;
  const std::vector<RunData> runs = plant_runs(fx, c_true, bt_true, 7);
  OutputErrorProblem pr;
  Controller ctl;
  ctl.kp = 2.0;
  for (const auto& r : runs) pr.runs.push_back({&r, ctl, 1.0, {}, {}});
  pr.parameters = {{"c", 5.0, 0.1, 100.0},
                   {"beta_tilde", 150.0, 1.0, 1e4},
                   {"coulomb_v", 0.0, 0.0, 1.0},
                   {"offset_v", 0.0, -1.0, 1.0}};
  pr.model = [](const double* p, std::size_t) {
    JointModelAtPose m;
    m.use_alpha = false;
    m.c_linear = p[0];
    m.beta_tilde_linear = p[1];
    m.effects.coulomb_v = p[2];
    m.effects.offset_v = p[3];
    return m;
  };
  pr.simulation.loop_period_s = 1e-3;
  const OutputErrorResult res = fit_output_error(pr);
  ASSERT_TRUE(res.ok) << res.message;
  EXPECT_NEAR(res.values[0], c_true, 0.02 * c_true);
  EXPECT_NEAR(res.values[1], bt_true, 0.02 * bt_true);
  EXPECT_NEAR(res.values[2], 0.01, 0.05 * 0.01);
  EXPECT_NEAR(res.values[3], -0.004, 0.05 * 0.004);
  // The residual is the measurement noise (quantisation q/√12 and σ): nothing systematic left.
  EXPECT_LT(res.rms, 1.5 * std::hypot(1.5e-4 / std::sqrt(12.0), 5e-5));
  for (std::size_t j = 0; j < 4; ++j) {
    EXPECT_TRUE(std::isfinite(res.standard_errors[j])) << j;
    EXPECT_GT(res.standard_errors[j], 0.0) << j;
  }
  // The truth lies within a few standard errors (they are optimistic: correlated residuals).
  EXPECT_LT(std::abs(res.values[0] - c_true), 20 * res.standard_errors[0] + 0.005 * c_true);
  EXPECT_TRUE(res.usable());
  EXPECT_EQ(res.parameter_names,
            (std::vector<std::string>{"c", "beta_tilde", "coulomb_v", "offset_v"}));
  // 216 simulations: the points Ceres asks for again (the projected line search's trial, then
  // the cost and Jacobian at the accepted step; the standard errors and RMS at the solution) are
  // not simulated again (429 before, with the same fit to the digit).
  EXPECT_EQ(res.brief_report(),
            "output-error fit: usable, 4 parameters, RMS of θ − θ_sim 7.684e-05, 7 iterations, "
            "216 simulations");
  const std::string full = res.full_report();
  for (const char* line : {"  c = 7.50096 ± 0.000315", "  offset_v = -0.00400017 ± 1.63e-06",
                           "  run 2: RMS of θ − θ_sim 7.076e-05"}) {
    EXPECT_NE(full.find(std::string("\n") + line + "\n"), std::string::npos)
        << line << "\n" << full;
  }
  EXPECT_NE(full.find("\n  Ceres Solver Report: Iterations: "), std::string::npos) << full;
}

TEST(OutputError, InitialStateIsTheFirstSampleAndSlope) {
  RunData d;
  for (int k = 0; k < 20; ++k) {
    d.t.push_back(1e-3 * k);
    d.r.push_back(0.0);
    d.theta.push_back(0.1 + 0.5 * 1e-3 * k);
    d.v.push_back(0.0);
  }
  const InitialState s = initial_state_of(d);
  EXPECT_DOUBLE_EQ(s.theta, 0.1);
  EXPECT_NEAR(s.theta_dot, 0.5, 1e-9);
}

TEST(OutputError, BadProblemsGiveAMessage) {
  OutputErrorProblem pr;
  EXPECT_FALSE(fit_output_error(pr).ok);
  RunData d;
  d.t = {0, 1};
  d.r = d.theta = d.v = {0, 0};
  pr.runs.push_back({&d, Controller{}, 1.0, {}, {}});
  pr.model = [](const double*, std::size_t) { return JointModelAtPose{}; };
  const OutputErrorResult r = fit_output_error(pr);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("fewer than 10"), std::string::npos) << r.message;
  const RunData e = resting_run(50);
  pr.runs = {{&e, Controller{}, 1.0, {}, {}}};
  pr.parameters = {{"c", 5.0, 6.0, 7.0}};
  EXPECT_NE(fit_output_error(pr).message.find("outside its bounds"), std::string::npos);
  EXPECT_EQ(fit_output_error(pr).brief_report(),
            "output-error fit: NOT usable: parameter c: initial value outside its bounds");
}

TEST(OutputError, InvalidOptionsAreNamedInTheResultNotThrown) {
  OutputErrorOptions o;
  EXPECT_NO_THROW(o.validate());
  const RunData e = resting_run(50);
  OutputErrorProblem pr;
  pr.runs = {{&e, Controller{}, 1.0, {}, {}}};
  pr.parameters = {{"c", 5.0, 1.0, 10.0}, {"beta_tilde", 200.0, 10.0, 1e3}};
  pr.model = [](const double*, std::size_t) { return JointModelAtPose{}; };
  o.max_iterations = 0;
  OutputErrorResult r = fit_output_error(pr, o);
  EXPECT_FALSE(r.usable());
  EXPECT_EQ(r.message, "invalid options: 'OutputErrorOptions::max_iterations': expected at least 1 "
                       "iteration, got 0");
  o = OutputErrorOptions{};
  o.extra_starts = {{5.0, 200.0}, {5.0, std::nan("")}};
  r = fit_output_error(pr, o);
  EXPECT_FALSE(r.usable());
  EXPECT_NE(r.message.find("'OutputErrorOptions::extra_starts[1][1]': expected a finite number"),
            std::string::npos)
      << r.message;
}

}  // namespace
}  // namespace alphainv
