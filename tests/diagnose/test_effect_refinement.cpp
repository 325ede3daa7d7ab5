// effect_refinement.hpp: a known effect's size settled on all runs. Ground truth: the virtual
// Omni's Coulomb friction and α-model.

#include <gtest/gtest.h>

#include <cmath>

#include "alphainv/diagnose/effect_refinement.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv {
namespace {

/// One pose of the paper's plan (the sine sweep and a square wave) with Coulomb friction `fc`,
/// seed 7. (With 2 to 5 poses the pipeline fits no inertia model and one α-model across poses,
/// which the friction cannot mend; one pose or the full plan are what it is built for.)
ExperimentPlanOptions one_pose_options(double fc) {
  ExperimentPlanOptions o = paper_plan_options(7);
  o.plant.effects.coulomb_v = fc;
  o.sine_poses = {{45, 90}};
  o.square_poses = o.sine_poses;
  return o;
}

/// Largest |C_fit/C_true − 1| over the data's α at the plan's poses.
double c_error(const DatasetFit& fit, const ExperimentPlan& plan) {
  double worst = 0.0;
  for (const SineRunPoint& sp : fit.sine_points) {
    if (!sp.point.physical) continue;
    const double a = sp.point.alpha_data;
    const double c_fit = fit.alpha.model.damping(a, fit.poses[sp.pose].inertia);
    const double c_true = plan.options.plant.alpha_model.damping(a, plan.poses[sp.pose].inertia);
    worst = std::max(worst, std::abs(c_fit / c_true - 1.0));
  }
  return worst;
}

TEST(EffectRefinement, SettlesTheFrictionFromAWrongStart) {
  const double fc = 0.004;
  const ExperimentPlan plan = make_experiment_plan(one_pose_options(fc));
  const GeneratedDataset g = generate_dataset(plan);
  FitPipelineOptions fo;
  fo.effects.coulomb_v = 1.4 * fc;  // 40 % high, as a diagnosis on a few runs can be
  EffectRefinement r;
  const DatasetFit fit = refine_effects(g.index, g.runs, fo, &r);
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_TRUE(fit.alpha.ok);
  EXPECT_EQ(r.parameters, std::vector<std::string>{"coulomb_v"});
  EXPECT_NEAR(r.refined.coulomb_v, fc, 0.1 * fc);
  EXPECT_LT(r.sse_refined, r.sse_start);
  EXPECT_EQ(fit.effects.coulomb_v, r.refined.coulomb_v);  // the fit returned is at the refined value
  EXPECT_GT(r.runs_scored, 0u);
  // The α-model with the settled friction: C(α) within 5 % of the plant's on the data.
  EXPECT_LT(c_error(fit, plan), 0.05);
}

TEST(EffectRefinement, WithoutEffectsSaysSoAndReturnsThePlainFit) {
  const GeneratedDataset g = generate_dataset(make_experiment_plan(one_pose_options(0.0)));
  EffectRefinement r;
  const DatasetFit fit = refine_effects(g.index, g.runs, FitPipelineOptions{}, &r);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("no active effect"), std::string::npos) << r.message;
  EXPECT_TRUE(fit.alpha.ok);
  EXPECT_EQ(r.evaluations, 1);
}

}  // namespace
}  // namespace alphainv
