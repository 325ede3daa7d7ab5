#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "alphainv/identify/alpha_fit.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {
namespace {

/// Local points of one pose from the α-model simulated (fixed point + RK4) at the Table 1 sweep.
AlphaFitPose simulated_pose(const AlphaModel& truth, double inertia, double kp, double ar) {
  AlphaFitPose pose;
  pose.inertia = inertia;
  JointModelAtPose m;
  m.inertia = inertia;
  m.alpha = truth;
  m.c_linear = truth.damping(25.0, inertia);
  m.beta_tilde_linear = truth.beta_tilde(25.0, inertia);
  Controller ctl;
  ctl.kp = kp;
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) {
    const SineReference ref(ar, f);
    const auto times = uniform_times(8.0, 1e-3);
    const SimulationResult res = simulate(m, ctl, ref, times);
    EXPECT_TRUE(res.ok);
    const IndexRange win = steady_state_window(times, f, 5.0);
    const SineFit fit = fit_sine(times.data() + win.begin, res.theta.data() + win.begin, win.size(),
                                 2 * kPi * f);
    pose.points.push_back(local_linear_point(f, fit.a1, fit.a2, ar, kp));
  }
  return pose;
}

std::vector<AlphaFitPose> paper_poses(const AlphaModel& truth) {
  // Table 5's true angles.
  const double angles[9][2] = {{21.54, 69.54}, {20.55, 88.54}, {19.31, 112.44},
                               {40.68, 68.52}, {39.83, 87.63}, {39.16, 111.98},
                               {60.68, 67.62}, {60.08, 87.00}, {59.56, 111.45}};
  const InertiaModel im = paper_inertia_model();
  std::vector<AlphaFitPose> poses;
  for (const auto& a : angles) {
    poses.push_back(simulated_pose(truth, im.inertia(deg_to_rad(a[0]), deg_to_rad(a[1])), 2.0, 0.07));
  }
  return poses;
}

TEST(AlphaFit, SteadyStateOfAlphaModelIsOnTheModel) {
  // In the sinusoidal steady state α is constant, so the loop is linear at C(α), β̃(α): the local
  // points (19)-(20) must lie on the model at α_data (36).
  const AlphaModel truth = paper_alpha_model();
  const double i = 0.004366;
  const AlphaFitPose pose = simulated_pose(truth, i, 2.0, 0.07);
  int physical = 0;
  for (const auto& p : pose.points) {
    if (!p.physical) continue;
    ++physical;
    EXPECT_NEAR(p.c_data, truth.damping(p.alpha_data, i), 0.01 * p.c_data) << p.freq_hz;
    EXPECT_NEAR(p.beta_data / 2.0, truth.beta_tilde(p.alpha_data, i), 0.005 * p.beta_data / 2.0);
  }
  EXPECT_GE(physical, 7);
}

TEST(AlphaFit, RecoversPaperModelWithKnownBreakpoints) {
  const AlphaModel truth = paper_alpha_model();
  const auto poses = paper_poses(truth);
  AlphaFitOptions opt;
  const AlphaFitResult r = fit_alpha_model_at(poses, {0.0, 2.2, 25.0, 250.0}, opt);
  ASSERT_TRUE(r.ok) << r.message;
  // Identifiable: the breakpoints the data's α (≈ 0.1 … 150) brackets.
  for (std::size_t n = 1; n < 4; ++n) {
    EXPECT_NEAR(r.model.c_n1[n], truth.c_n1[n], 0.02 * truth.c_n1[n]) << "C_" << n << "1";
  }
  EXPECT_NEAR(r.model.beta_n1[0], truth.beta_n1[0], 0.02 * truth.beta_n1[0]);
  EXPECT_NEAR(r.model.beta_n1[1], truth.beta_n1[1], 0.02 * truth.beta_n1[1]);
  EXPECT_LT(r.c_rms_relative, 0.01);
  EXPECT_LT(r.beta_rms_relative, 0.005);
}

TEST(AlphaFit, GridSearchPredictsDampingOfUnseenModel) {
  // A different truth (not the paper's numbers): the searched model predicts C and β̃ on the data.
  AlphaModel truth;
  truth.n_breakpoints = 4;
  truth.alpha = {0.0, 5.0, 40.0, 300.0};
  truth.c_n1 = {10.0, 18.0, 30.0, 50.0};
  truth.beta_alpha = {0.0, 300.0};
  truth.beta_n1 = {0.9, 1.2};
  const auto poses = paper_poses(truth);
  const AlphaFitResult r = fit_alpha_model(poses, AlphaFitOptions{});
  ASSERT_TRUE(r.ok) << r.message;
  EXPECT_GT(r.candidates_tried, 100u);
  EXPECT_LT(r.c_rms_relative, 0.03);
  EXPECT_LT(r.beta_rms_relative, 0.01);
}

/// max |C_fit/C_true − 1| over the α each pose's physical points cover (log grid).
double max_damping_error_on_data(const std::vector<AlphaFitPose>& poses, const AlphaModel& fit,
                                 const AlphaModel& truth) {
  double worst = 0.0;
  for (const auto& pose : poses) {
    double lo = INFINITY, hi = 0.0;
    for (const auto& p : pose.points) {
      if (!p.physical) continue;
      lo = std::min(lo, p.alpha_data);
      hi = std::max(hi, p.alpha_data);
    }
    for (int k = 0; k <= 60; ++k) {
      const double a = lo * std::pow(hi / lo, k / 60.0);
      worst = std::max(worst,
                       std::abs(fit.damping(a, pose.inertia) / truth.damping(a, pose.inertia) - 1));
    }
  }
  return worst;
}

TEST(AlphaFit, NelderMeadRefinementMovesBreakpointsOffTheGridTowardsTheTruth) {
  // The same unseen truth: its breakpoints 5 and 40 are not on the log grid. The local search from
  // the grid winner must lower the score, bring C(α) on the data closer to the truth and put the
  // breakpoints the data pin down near the truth's.
  AlphaModel truth;
  truth.n_breakpoints = 4;
  truth.alpha = {0.0, 5.0, 40.0, 300.0};
  truth.c_n1 = {10.0, 18.0, 30.0, 50.0};
  truth.beta_alpha = {0.0, 300.0};
  truth.beta_n1 = {0.9, 1.2};
  const auto poses = paper_poses(truth);
  AlphaFitOptions grid_only;
  grid_only.refine = false;
  const AlphaFitResult g = fit_alpha_model(poses, grid_only);
  const AlphaFitResult r = fit_alpha_model(poses, AlphaFitOptions{});
  ASSERT_TRUE(g.ok && r.ok);
  EXPECT_FALSE(g.refined);
  EXPECT_TRUE(r.refined);
  EXPECT_GT(r.refine_evaluations, 0);
  EXPECT_DOUBLE_EQ(r.grid_score, g.score);
  EXPECT_LT(r.score, 0.5 * g.score);
  const double err_grid = max_damping_error_on_data(poses, g.model, truth);
  const double err_refined = max_damping_error_on_data(poses, r.model, truth);
  std::printf(
      "  [refinement] score %.3g -> %.3g, max C(alpha) error on the data %.2f %% -> %.2f %%, "
      "breakpoints %.3g %.3g %.3g (data alpha %.3g ... %.3g)\n",
      g.score, r.score, 100 * err_grid, 100 * err_refined, r.model.alpha[1], r.model.alpha[2],
      r.model.alpha[3], r.alpha_data_min, r.alpha_data_max);
  EXPECT_LT(err_refined, err_grid);
  EXPECT_LT(err_refined, 0.02);
  // The truth's α3 = 300 is above every α of the sweep: wherever the search puts α3, it is flagged
  // as not pinned when it lies beyond the data.
  if (r.model.alpha[3] > r.alpha_data_max) {
    EXPECT_FALSE(r.breakpoint_identifiable[3]);
    EXPECT_FALSE(r.c_n1_identifiable[3]);
  }
  for (std::size_t n = 1; n < 3; ++n) {
    ASSERT_TRUE(r.breakpoint_identifiable[n]) << n;
    EXPECT_NEAR(r.model.alpha[n], truth.alpha[n], 0.1 * truth.alpha[n]) << "alpha_" << n;
  }
}

TEST(AlphaFit, RunnersUpAreTheNextBestGridSetsInOrder) {
  // keep_runners_up: the grid's next best breakpoint sets after the winner, best first, each one
  // scoring no better than the winner, and distinct from it and from each other.
  const auto poses = paper_poses(paper_alpha_model());
  AlphaFitOptions o;
  o.refine = false;
  o.keep_runners_up = 5;
  const AlphaFitResult r = fit_alpha_model(poses, o);
  ASSERT_TRUE(r.ok);
  ASSERT_EQ(r.runners_up.size(), 5u);
  double previous = r.score;
  std::vector<std::vector<double>> seen{
      std::vector<double>(r.model.alpha.begin(), r.model.alpha.begin() + 4)};
  for (const auto& bp : r.runners_up) {
    ASSERT_EQ(bp.size(), 4u);
    EXPECT_EQ(bp[0], 0.0);
    const AlphaFitResult at = fit_alpha_model_at(poses, bp, o);
    ASSERT_TRUE(at.ok);
    EXPECT_GE(at.score, previous);
    previous = at.score;
    EXPECT_EQ(std::find(seen.begin(), seen.end(), bp), seen.end());
    seen.push_back(bp);
  }
  // Off by default.
  EXPECT_TRUE(fit_alpha_model(poses, AlphaFitOptions{}).runners_up.empty());
}

TEST(AlphaFit, BreakpointsAndCoefficientsBeyondTheDataAreFlaggedNotIdentifiable) {
  // The paper's α3 = 250 lies above every α of the ±0.07 rad sweep (≈ 150 at most): neither it nor
  // C_31 nor β̃ at ᾱ1 = 250 is measured; α1 = 2.2 and α2 = 25 have data on both sides.
  const AlphaModel truth = paper_alpha_model();
  const auto poses = paper_poses(truth);
  const AlphaFitResult r = fit_alpha_model_at(poses, {0.0, 2.2, 25.0, 250.0}, AlphaFitOptions{});
  ASSERT_TRUE(r.ok);
  ASSERT_LT(r.alpha_data_max, 250.0);
  EXPECT_GT(r.alpha_data_max, 25.0);
  EXPECT_FALSE(r.breakpoint_identifiable[0]);  // α0 = 0: a convention
  EXPECT_TRUE(r.breakpoint_identifiable[1]);
  EXPECT_TRUE(r.breakpoint_identifiable[2]);
  EXPECT_FALSE(r.breakpoint_identifiable[3]);
  EXPECT_TRUE(r.c_n1_identifiable[1]);
  EXPECT_TRUE(r.c_n1_identifiable[2]);
  EXPECT_FALSE(r.c_n1_identifiable[3]);
  EXPECT_TRUE(r.beta_n1_identifiable[0]);
  EXPECT_FALSE(r.beta_n1_identifiable[1]);
}

TEST(AlphaFit, PoseInertiaFromTheAlphaModelIsTheTrueInertia) {
  // The α-model's own steady states: the inertia that best fits the truth to each pose's points is
  // that pose's inertia (to the local points' accuracy, < 1 %).
  const AlphaModel truth = paper_alpha_model();
  const auto poses = paper_poses(truth);
  const std::vector<double> inertia = alpha_model_pose_inertia(poses, truth, 2.0);
  ASSERT_EQ(inertia.size(), poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_NEAR(inertia[k], poses[k].inertia, 0.01 * poses[k].inertia) << k;
  }
}

TEST(AlphaFit, BadInputGivesMessage) {
  EXPECT_FALSE(fit_alpha_model({}, AlphaFitOptions{}).ok);
  AlphaFitOptions opt;
  opt.n_breakpoints = 1;
  EXPECT_FALSE(fit_alpha_model({}, opt).ok);
  EXPECT_FALSE(fit_alpha_model_at({}, {0.0, 1.0, 1.0}, AlphaFitOptions{}).ok);
  AlphaFitPose nonphysical;
  nonphysical.points.push_back(local_linear_point(1.5, -0.002, 0.02, 0.07, 2.0));
  const AlphaFitResult r = fit_alpha_model({nonphysical}, AlphaFitOptions{});
  EXPECT_FALSE(r.ok);
  EXPECT_FALSE(r.message.empty());
}

}  // namespace
}  // namespace alphainv
