// Tests of include/alphainv/identify/gravity_search.hpp: gravity's (g, θ0) found globally.
// Ground truth: a pendulum-like plant θ̈ + C·θ̇ = β̃·(v − g·sin(θ + θ0)) under a P law, swung
// over ±1.2 rad by multisine references, with its gravity at phases far from 0 (θ0 = 2.5 rad and
// −2.0 rad), measured with noise (seeded).
#include "alphainv/identify/gravity_search.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>

#include "alphainv/simulate/reference.hpp"

namespace alphainv {
namespace {

constexpr double kC = 4.0, kBeta = 40.0, kKp = 8.0;

/// Two 5 s multisine runs at 200 Hz of the plant with gravity (g, θ0), θ measured with σ = 1e-3
/// rad of noise (seed `seed`).
void pendulum_runs(double g, double theta0, unsigned seed, Dataset& ds, std::vector<RunData>& data) {
  JointModelAtPose m;
  m.use_alpha = false;
  m.c_linear = kC;
  m.beta_tilde_linear = kBeta;
  m.effects.gravity_v = g;
  m.effects.gravity_theta0_rad = theta0;
  Controller ctl;
  ctl.kp = kKp;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1e-3);
  for (int run = 0; run < 2; ++run) {
    const std::vector<double> t = uniform_times(5.0, 5e-3);
    std::vector<double> r(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
      const double s = t[k];
      r[k] = 0.5 * std::sin(2 * kPi * 0.3 * s + run) + 0.4 * std::sin(2 * kPi * 0.7 * s + 2.0 * run) +
             0.3 * std::sin(2 * kPi * 1.3 * s + 1.0);
    }
    const SampledReference ref(t, r);
    // Started at rest where the P law holds gravity against r(0).
    double th = r[0];
    for (int it = 0; it < 50; ++it) th = r[0] - g * std::sin(th + theta0) / kKp;
    const SimulationResult s = simulate(m, ctl, ref, t, {th, 0.0, 0.0});
    ASSERT_TRUE(s.ok) << s.message;
    RunData d;
    d.t = t;
    d.r = r;
    d.v = s.v;
    d.theta = s.theta;
    for (double& x : d.theta) x += noise(rng);
    data.push_back(d);
    RunInfo info;
    info.file = "run" + std::to_string(run) + ".csv";
    info.kind = "other";
    info.controller = ctl;
    ds.runs.push_back(info);
  }
}

TEST(GravitySearch, NormalFormHasAPositiveAmplitudeAndAPhaseInMinusPiPi) {
  const GravityPoint a = normal_gravity(-2.0, 0.5);
  EXPECT_DOUBLE_EQ(a.g, 2.0);
  EXPECT_NEAR(a.theta0, 0.5 + kPi - 2 * kPi, 1e-12);
  EXPECT_NEAR(normal_gravity(1.0, 7.0).theta0, 7.0 - 2 * kPi, 1e-12);
  EXPECT_NEAR(normal_gravity(1.0, -kPi).theta0, kPi, 1e-12);  // −π is π: the interval is (−π, π]
  // The same torque: −g·sin(θ + θ0) at any θ.
  for (double th : {-1.0, 0.3, 2.0}) {
    EXPECT_NEAR(-a.g * std::sin(th + a.theta0), 2.0 * std::sin(th + 0.5), 1e-12);
  }
}

TEST(GravitySearch, TheGridFindsAPhaseFarFromZero) {
  for (const auto& [g, theta0, seed] : {std::tuple{1.5, 2.5, 11u}, std::tuple{0.8, -2.0, 23u}}) {
    Dataset ds;
    std::vector<RunData> data;
    pendulum_runs(g, theta0, seed, ds, data);
    const TimeDomainGravityCost cost(ds, data, Effects{}, SimulationOptions{});
    ASSERT_EQ(cost.runs(), 2u);
    GravitySearchOptions o;
    o.amplitudes = gravity_grid_amplitudes(cost.v_max());
    o.threads = 2;
    // The start the fit gets without a search: the right size at θ0 = 0.
    const GravitySearchResult r = search_gravity(cost, o, {{g, 0.0, 0.0}});
    ASSERT_TRUE(r.ok) << r.message;
    EXPECT_EQ(r.grid.size(), 6u * 16u + 1u);
    EXPECT_NEAR(r.best.theta0, theta0, 0.03) << "g " << g;
    EXPECT_NEAR(r.best.g, g, 0.03 * g);
    EXPECT_LE(r.best.cost, r.grid_best.cost);
    // The cost (its C, β̃ from the noisy equation error) at the truth: the search is no worse.
    EXPECT_LE(r.best.cost, cost(g, theta0) * (1.0 + 1e-6));
    // The equation-error start (one linear least squares) is also near the truth here.
    GravityPoint ee;
    ASSERT_TRUE(cost.equation_error_start(ee));
    EXPECT_NEAR(ee.theta0, theta0, 0.1);
    EXPECT_NEAR(ee.g, g, 0.1 * g);
  }
}

TEST(GravitySearch, SaysWhyWhenNothingCanBeScored) {
  GravitySearchOptions o;
  const GravitySearchResult none = search_gravity([](double, double) { return 1.0; }, o);
  EXPECT_FALSE(none.ok);
  EXPECT_NE(none.message.find("amplitudes"), std::string::npos);
  o.amplitudes = {1.0};
  const GravitySearchResult fails = search_gravity(
      [](double, double) { return std::numeric_limits<double>::infinity(); }, o);
  EXPECT_FALSE(fails.ok);
  EXPECT_NE(fails.message.find("failed at every grid point"), std::string::npos);
}

}  // namespace
}  // namespace alphainv
