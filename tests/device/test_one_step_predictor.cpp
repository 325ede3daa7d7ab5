// OneStepPredictor: the model's one-step prediction of θ made from the tick records (eq. (37)
// over one tick with C, β̃ and u held). Against the closed-form solution of that equation, with
// C, β̃ and v changing every tick, the model's delay, an offset and Coulomb friction; the records
// of a fault and a gap (no prediction across them); no allocation per record. (The loop with the
// virtual plant, and the equality with the prediction the tick used to make, are in
// test_control_loop.cpp.)
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "support/counting_allocator.hpp"
#include "alphainv/device/one_step_predictor.hpp"
#include "alphainv/model/plant_input.hpp"

using namespace alphainv;
using namespace alphainv::rt;

namespace {

/// Records of the plant θ̈ + C_k θ̇ = β̃_k u_k solved exactly over each tick k (C_k, β̃_k, u_k
/// held), u_k = S(Z(v_{k−d})) + n(θ_k, θ̇_k) with the effects of `c`: the sequence whose
/// prediction is exact to rounding. C, β̃ and v are drawn from `seed`.
std::vector<TickRecord> exact_plant_records(const ControlLoopConfig& c, int ticks, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> damping(20.0, 60.0), beta(300.0, 900.0),
      command(-0.3, 0.3);
  const double T = c.period_s;
  const auto delay = static_cast<std::size_t>(std::lround(c.effects.delay_s / T));
  std::vector<TickRecord> recs;
  std::vector<double> sent;
  double theta = 0.01, theta_dot = 0.0;
  for (int k = 0; k < ticks; ++k) {
    TickRecord r;
    r.t_s = k * T;
    r.theta_rad = theta;
    r.new_report = true;
    r.enable = true;
    r.command_v = command(rng);
    r.damping = damping(rng);
    r.beta_tilde = beta(rng);
    sent.push_back(r.command_v);
    const double delayed = sent.size() > delay ? sent[sent.size() - 1 - delay] : 0.0;
    const double u = applied_command(c.effects, delayed) +
                     effect_torque(c.effects, theta, theta_dot);
    const double e = std::exp(-r.damping * T);
    const double a = (1.0 - e) / r.damping;
    const double g = r.beta_tilde / r.damping * u;
    theta = theta + theta_dot * a + g * (T - a);
    theta_dot = theta_dot * e + g * (1.0 - e);
    recs.push_back(r);
  }
  return recs;
}

/// The largest |θ_pred − θ| over records 2 … (the first two have no prediction) and whether
/// records 0 and 1 carry their own θ.
double worst_prediction_error(const ControlLoopConfig& c, std::vector<TickRecord> recs) {
  OneStepPredictor p(c);
  double worst = 0.0;
  for (std::size_t k = 0; k < recs.size(); ++k) {
    p.add(recs[k]);
    if (k < 2) {
      EXPECT_EQ(recs[k].theta_pred_rad, recs[k].theta_rad) << "record " << k;
    } else {
      worst = std::max(worst, std::abs(recs[k].theta_pred_rad - recs[k].theta_rad));
    }
  }
  return worst;
}

}  // namespace

TEST(OneStepPredictor, EqualsTheClosedFormSolutionWithCBetaAndTheCommandChangingEveryTick) {
  ControlLoopConfig c;
  for (unsigned seed : {3u, 17u}) {
    const std::vector<TickRecord> recs = exact_plant_records(c, 500, seed);
    EXPECT_GT(std::abs(recs.back().theta_rad - recs.front().theta_rad) +
                  std::abs(recs[250].theta_rad - recs.front().theta_rad),
              1e-4);  // it moves
    EXPECT_LT(worst_prediction_error(c, recs), 1e-12) << "seed " << seed;
  }
}

TEST(OneStepPredictor, HonoursTheModelsDelayOffsetDeadzoneAndFriction) {
  ControlLoopConfig c;
  c.effects.delay_s = 0.003;
  c.effects.offset_v = 0.02;
  c.effects.deadzone_v = 0.01;
  c.effects.coulomb_v = 0.05;
  const std::vector<TickRecord> recs = exact_plant_records(c, 500, 29);
  EXPECT_LT(worst_prediction_error(c, recs), 1e-12);
  // The predictor can tell: without the effects (or with another delay) it misses.
  EXPECT_GT(worst_prediction_error(ControlLoopConfig{}, recs), 1e-7);
  ControlLoopConfig other_delay = c;
  other_delay.effects.delay_s = 0.002;
  EXPECT_GT(worst_prediction_error(other_delay, recs), 1e-7);
}

TEST(OneStepPredictor, MakesNoPredictionAcrossAFaultATickWithoutReportOrAGap) {
  ControlLoopConfig c;
  std::vector<TickRecord> recs = exact_plant_records(c, 40, 5);
  // Encoder noise of 1e-6 rad: a prediction is then never θ itself, to the bit.
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 1e-6);
  for (TickRecord& r : recs) r.theta_rad += noise(rng);
  recs[10].enable = false;  // the tick sent 0, disabled (a fault): predicted, then 2 records not
  recs[20].new_report = false;  // θ held
  OneStepPredictor p(c);
  for (int k = 0; k < 40; ++k) {
    if (k == 30) p.reset();  // records dropped before this one
    TickRecord r = recs[k];
    p.add(r);
    const bool none = k < 2 || (k >= 11 && k <= 12) || (k >= 20 && k <= 22) || (k >= 30 && k <= 31);
    if (none) {
      EXPECT_EQ(r.theta_pred_rad, r.theta_rad) << "record " << k;
    } else {  // two records with reports after each: predicted again (no delay to refill)
      EXPECT_NEAR(r.theta_pred_rad, r.theta_rad, 2e-5) << "record " << k;
      EXPECT_NE(r.theta_pred_rad, r.theta_rad) << "record " << k;  // a prediction, not θ copied
    }
  }
}

TEST(OneStepPredictor, AllocatesNothingPerRecord) {
  ControlLoopConfig c;
  c.effects.delay_s = 0.01;
  c.effects.coulomb_v = 0.05;
  std::vector<TickRecord> recs = exact_plant_records(c, 1000, 7);
  OneStepPredictor p(c);
  const long before = alphainv::test::allocation_count();
  for (TickRecord& r : recs) p.add(r);
  p.reset();
  EXPECT_EQ(alphainv::test::allocation_count() - before, 0);
}
