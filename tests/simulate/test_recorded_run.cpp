// Tests of include/alphainv/simulate/recorded_run.hpp: runs of the virtual plant with known
// disturbance pulses and the motor switched off part of the time, simulated back with the plant's
// own model — with the known inputs the simulation is the run (ground truth), without them it is
// not.
#include "alphainv/simulate/recorded_run.hpp"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "alphainv/simulate/reference.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv {
namespace {

double rms_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double ss = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) ss += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(ss / static_cast<double>(a.size()));
}

struct PlantRun {
  VirtualOmniParams params;
  Controller controller;
  RunData data;
  JointModelAtPose model;
};

/// The plant's own model (its α-model, inertia and effects) at the pose of `omni`.
JointModelAtPose own_model(const VirtualOmniParams& params, const VirtualOmni& omni) {
  JointModelAtPose m;
  m.use_alpha = true;
  m.inertia = omni.inertia();
  m.alpha = params.alpha_model;
  m.c_linear = params.alpha_model.damping(0.0, m.inertia);
  m.beta_tilde_linear = params.alpha_model.beta_tilde(0.0, m.inertia);
  m.effects = params.effects;
  return m;
}

/// A 4 s run at 2 Hz of the plant (paper models, Coulomb friction), noise-free, with ±`pulse_v`
/// pulses of 0.1 s every 0.7 s and, when `motor_off`, the motor off in [2.0, 2.3) s.
PlantRun plant_run(double pulse_v, bool motor_off) {
  PlantRun p;
  p.params.effects.coulomb_v = 0.004;
  p.controller.kp = 2.0;
  VirtualOmni omni(p.params);
  ClosedLoopOptions o;
  o.disturbance_v = [pulse_v](double t) {
    const double phase = std::fmod(t, 0.7);
    return phase >= 0.3 && phase < 0.4 ? (std::fmod(t, 1.4) < 0.7 ? pulse_v : -pulse_v) : 0.0;
  };
  if (motor_off) o.torque_enable = [](double t) { return !(t >= 2.0 && t < 2.3); };
  const SineReference ref(0.07, 2.0);
  p.data = run_closed_loop(omni, p.controller, ref, 4.0, o);
  p.model = own_model(p.params, omni);
  return p;
}

/// Simulates `p`'s run back as the digital loop from rest, with its recorded known inputs and
/// without them: with them it is the run to rounding; without them it is at least
/// `min_gap_without_rad` (RMS) away.
void expect_known_inputs_reproduce_the_run(const PlantRun& p, double min_gap_without_rad) {
  SimulationOptions so;
  so.loop_period_s = p.params.tick_period_s;
  const InitialState x0(p.data.theta[0], 0.0);  // the plant starts at rest
  const SimulationResult with = simulate_recorded_run(p.model, p.controller, p.data, x0, so);
  ASSERT_TRUE(with.ok) << with.message;
  ASSERT_EQ(with.theta.size(), p.data.size());
  EXPECT_LT(rms_difference(with.theta, p.data.theta), 1e-12);
  EXPECT_LT(rms_difference(with.v, p.data.v), 1e-10);
  const SimulationResult without =
      simulate_recorded_run(p.model, p.controller, p.data, x0, so, KnownInputUse::kIgnore);
  ASSERT_TRUE(without.ok) << without.message;
  EXPECT_GT(rms_difference(without.theta, p.data.theta), min_gap_without_rad);
}

TEST(RecordedRun, WithItsKnownInputsTheDigitalLoopIsTheRun) {
  const PlantRun p = plant_run(0.05, true);
  ASSERT_NE(p.data.column("disturbance_v"), nullptr);
  ASSERT_NE(p.data.column("torque_enable"), nullptr);
  // The same plant, controller, reference and inputs: equal to rounding; without them the
  // pulses of 0.05 V are visible.
  expect_known_inputs_reproduce_the_run(p, 1e-3);
}

TEST(RecordedRun, ACompensatedRunIsSimulatedWithItsRecordedCompensation) {
  // The plant's Coulomb friction (0.004 V) and an offset (0.01 V), compensated as omni_ctl
  // --compensate does, from the measured angle: c_k = 0.004·tanh(θ̇_k/0.01) − 0.01 with θ̇_k
  // the measured angle's backward difference. The run records c as `v_comp`.
  PlantRun p;
  p.params.effects.coulomb_v = 0.004;
  p.params.effects.offset_v = 0.01;
  // The simulation takes the command history before t0 to be the first command (kp·0 + c_0 =
  // −0.01 V here, the plant at rest on the sine's start): the plant held it too.
  p.params.initial_command_v = -0.01;
  VirtualOmni omni(p.params);
  ClosedLoopOptions o;
  double theta_prev = 0.0;
  bool first = true;
  o.command_offset_v = [&](double, double theta) {
    const double w = first ? 0.0 : (theta - theta_prev) / p.params.tick_period_s;
    first = false;
    theta_prev = theta;
    return 0.004 * std::tanh(w / 0.01) - 0.01;
  };
  p.data = run_closed_loop(omni, p.controller, SineReference(0.07, 2.0), 4.0, o);
  const std::vector<double>* comp = p.data.column("v_comp");
  ASSERT_NE(comp, nullptr);
  EXPECT_GT(*std::max_element(comp->begin(), comp->end()), -0.0065);
  EXPECT_LT(*std::min_element(comp->begin(), comp->end()), -0.0135);
  p.model = own_model(p.params, omni);
  // The plant's own model under the recorded command clamp(kp·e + c): the run, to rounding;
  // without it the P law alone meets the uncompensated offset and friction.
  expect_known_inputs_reproduce_the_run(p, 2e-3);
}

TEST(RecordedRun, TheContinuousSimulatorHoldsTheKnownInputsOverEachSample) {
  const SimulationOptions so;  // RK4 on the continuous law (43), not the plant's sampled loop
  // Without pulses, what is left is the continuous law against the sampled one and the plant's
  // α filter lag (7.8e-4 rad at kp = 2, 2 Hz).
  const PlantRun calm = plant_run(0.0, false);
  const InitialState x0(calm.data.theta[0], 0.0);
  const double floor =
      rms_difference(simulate_recorded_run(calm.model, calm.controller, calm.data, x0, so).theta,
                     calm.data.theta);
  EXPECT_LT(floor, 1.5e-3);
  for (double pulse_v : {0.03, 0.1}) {
    const PlantRun p = plant_run(pulse_v, false);
    const SimulationResult with = simulate_recorded_run(p.model, p.controller, p.data, x0, so);
    const SimulationResult without =
        simulate_recorded_run(p.model, p.controller, p.data, x0, so, KnownInputUse::kIgnore);
    ASSERT_TRUE(with.ok && without.ok) << with.message << without.message;
    const double e_with = rms_difference(with.theta, p.data.theta);
    const double e_without = rms_difference(without.theta, p.data.theta);
    EXPECT_LT(e_with, 3.0 * floor) << pulse_v;  // the pulses are followed: near the floor
    EXPECT_GT(e_without, 4.0 * e_with) << pulse_v;
  }
}

TEST(RecordedRun, AMotorSwitchedOffIsFreeMotion) {
  expect_known_inputs_reproduce_the_run(plant_run(0.0, true), 1e-3);
}

TEST(RecordedRun, AnOpenLoopRunIsDrivenByItsRecordedCommand) {
  // No controller: the plant driven by a recorded voltage (two sines), held over each tick.
  PlantRun p = plant_run(0.0, false);
  VirtualOmni omni(p.params);
  RunData d;
  for (int k = 0; k <= 3000; ++k) {
    const double t = 1e-3 * k;
    d.t.push_back(t);
    d.r.push_back(0.0);
    d.theta.push_back(omni.theta_measured());
    d.v.push_back(0.2 * std::sin(2 * M_PI * 1.3 * t) + 0.1 * std::sin(2 * M_PI * 4.1 * t));
    (void)omni.step(d.v.back());
  }
  const Controller none{0.0, 0.0, 0.0};
  ASSERT_TRUE(is_open_loop(none));
  SimulationOptions digital;
  digital.loop_period_s = 1e-3;
  const InitialState x0(0.0, 0.0);
  const SimulationResult s = simulate_recorded_run(p.model, none, d, x0, digital);
  ASSERT_TRUE(s.ok) << s.message;
  EXPECT_LT(rms_difference(s.theta, d.theta), 1e-12);  // the plant's own loop
  EXPECT_EQ(s.v, d.v);                                 // the command is the recorded one
  // The continuous law: α of the interpolated command, θ within the hold's half-tick delay.
  const SimulationResult c = simulate_recorded_run(p.model, none, d, x0, SimulationOptions{});
  ASSERT_TRUE(c.ok) << c.message;
  double peak = 0.0;
  for (double th : d.theta) peak = std::max(peak, std::abs(th));
  EXPECT_GT(peak, 0.05);
  EXPECT_LT(rms_difference(c.theta, d.theta), 0.03 * peak);
}

TEST(RecordedRun, AnEmptyRunSaysSo) {
  const SimulationResult s =
      simulate_recorded_run(JointModelAtPose{}, Controller{}, RunData{}, InitialState{}, {});
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("no samples"), std::string::npos) << s.message;
}

TEST(RecordedRun, TheStateOfAWindowIsMeasuredFromBothSidesOfItsStart) {
  // θ = A sin(ωt) at 1 kHz, 7 Hz, A = 0.01 rad (the fastest sine run of the paper's plan), with
  // Gaussian noise σ = 2e-4 rad: at sample k the centred quartic over ±20 ms recovers θ and θ̇.
  constexpr double kPi = 3.141592653589793;
  const double a = 0.01, w = 2.0 * kPi * 7.0, sigma = 2e-4;
  RunData d;
  unsigned state = 12345u;
  const auto gauss = [&] {  // Box-Muller on a small LCG: the test needs no library generator
    const auto u = [&] {
      state = 1664525u * state + 1013904223u;
      return (static_cast<double>(state >> 8) + 0.5) / 16777216.0;
    };
    const double u1 = u(), u2 = u();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  };
  for (int k = 0; k <= 2000; ++k) {
    const double t = 1e-3 * k;
    d.t.push_back(t);
    d.r.push_back(0.0);
    d.v.push_back(0.0);
    d.theta.push_back(a * std::sin(w * t));
  }
  // Noise-free: exact to the fit's truncation (6e-4 rad/s in θ̇ at 7 Hz by the 5th-order term,
  // where θ̇ peaks at a·ω = 0.44 rad/s; 2e-6 rad in θ by the 6th-order).
  for (std::size_t k : {100u, 537u, 1000u, 1980u}) {
    const MeasuredStart m = measured_state_at(d, k);
    const double t = d.t[k];
    EXPECT_NEAR(m.theta_rad, a * std::sin(w * t), 5e-6) << k;
    EXPECT_NEAR(m.theta_dot_rad_s, a * w * std::cos(w * t), 1e-3) << k;
  }
  // With noise, over 200 starts: the RMS error of θ̇ is near the fit's 33·σ (6.6e-3 rad/s),
  // a tenth of the one-sided quadratic's through the first 10 ms of a window (initial_state_of(),
  // 354·σ = 0.071 rad/s).
  for (double& x : d.theta) x += sigma * gauss();
  double ss_centred = 0.0, ss_one_sided = 0.0;
  int n = 0;
  for (std::size_t k = 50; k < 1950; k += 9) {
    const double truth = a * w * std::cos(w * d.t[k]);
    const MeasuredStart m = measured_state_at(d, k);
    ss_centred += (m.theta_dot_rad_s - truth) * (m.theta_dot_rad_s - truth);
    const InitialState one_sided = initial_state_of(d.rows(k, d.size()));
    ss_one_sided += (one_sided.theta_dot - truth) * (one_sided.theta_dot - truth);
    ++n;
  }
  const double rms_centred = std::sqrt(ss_centred / n), rms_one_sided = std::sqrt(ss_one_sided / n);
  EXPECT_GT(rms_centred, 20.0 * sigma);
  EXPECT_LT(rms_centred, 50.0 * sigma);
  EXPECT_LT(rms_centred, 0.2 * rms_one_sided) << rms_centred << " against " << rms_one_sided;
  // At a record's ends (no samples on one side) and out of range: not known (NaN), and
  // initial_state_of() with it falls back on the run's own first samples.
  EXPECT_TRUE(std::isnan(measured_state_at(d, 0).theta_dot_rad_s));
  EXPECT_TRUE(std::isnan(measured_state_at(d, 5).theta_rad));
  EXPECT_TRUE(std::isnan(measured_state_at(d, d.size() - 3).theta_dot_rad_s));
  EXPECT_TRUE(std::isnan(measured_state_at(d, d.size()).theta_rad));
  const RunData window = d.rows(600, d.size());
  const InitialState own = initial_state_of(window);
  const InitialState unknown = initial_state_of(window, MeasuredStart{}, {0.1, 0.2});
  EXPECT_EQ(unknown.theta, own.theta);
  EXPECT_EQ(unknown.theta_dot, own.theta_dot);
  EXPECT_EQ(unknown.command_history, (std::vector<double>{0.1, 0.2}));
  const MeasuredStart there = measured_state_at(d, 600);
  const InitialState measured = initial_state_of(window, there, {});
  EXPECT_EQ(measured.theta, there.theta_rad);
  EXPECT_EQ(measured.theta_dot, there.theta_dot_rad_s);
}

}  // namespace
}  // namespace alphainv
