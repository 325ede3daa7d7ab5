#include "alphainv/diagnose/external_disturbance.hpp"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv {
namespace {

constexpr double kTwoPi = 6.283185307179586476925;

/// 1 kHz samples over `seconds`, n̂ = a 2 Hz sine of the state (0.01) + white noise (0.01).
void base_signal(double seconds, std::vector<double>& t, std::vector<double>& n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (int k = 0; k < static_cast<int>(seconds * 1000); ++k) {
    t.push_back(1e-3 * k);
    n.push_back(0.01 * std::sin(kTwoPi * 2.0 * t.back()) + noise(rng));
  }
}

/// The functions of the "state" of base_signal (its 2 Hz sine), as a caller passes them.
std::vector<std::vector<double>> state_of(const std::vector<double>& t) {
  std::vector<std::vector<double>> b(2, std::vector<double>(t.size()));
  for (std::size_t k = 0; k < t.size(); ++k) {
    b[0][k] = std::sin(kTwoPi * 2.0 * t[k]);
    b[1][k] = std::cos(kTwoPi * 2.0 * t[k]);
  }
  return b;
}

TEST(LocateDisturbance, FindsTwoPulsesWithTheirEdgesAndLevels) {
  std::vector<double> t, n;
  base_signal(6.0, t, n, 3);
  std::vector<double> truth(t.size(), 0.0);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] >= 1.2305 && t[k] < 1.3805) truth[k] = 0.05;
    if (t[k] >= 3.5005 && t[k] < 3.6005) truth[k] = -0.04;
    n[k] += truth[k];
  }
  // Without the state fitted, the sine's spread hides the pulses; with it, they stand out.
  EXPECT_TRUE(locate_disturbance(t, n).intervals.empty());
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, {}, state_of(t));
  ASSERT_TRUE(d.ok) << d.message;
  ASSERT_EQ(d.intervals.size(), 2u);
  EXPECT_NEAR(d.intervals[0].start_s, 1.231, 0.005);
  EXPECT_NEAR(d.intervals[0].end_s, 1.381, 0.005);
  EXPECT_NEAR(d.intervals[0].level_v, 0.05, 0.005);
  EXPECT_NEAR(d.intervals[1].start_s, 3.501, 0.005);
  EXPECT_NEAR(d.intervals[1].end_s, 3.601, 0.005);
  EXPECT_NEAR(d.intervals[1].level_v, -0.04, 0.005);
  EXPECT_GT(d.intervals[0].spreads, 6.0);
  // The series: the pulses' samples carry their level, every other sample 0.
  double err = 0.0, ref = 0.0;
  for (std::size_t k = 0; k < t.size(); ++k) err += std::pow(d.d_v[k] - truth[k], 2), ref += truth[k] * truth[k];
  EXPECT_LT(std::sqrt(err / ref), 0.2);
  EXPECT_NEAR(d.rms_v, std::sqrt(ref / static_cast<double>(t.size())), 0.002);
}

TEST(LocateDisturbance, FindsAStepThatLastsToTheEnd) {
  std::vector<double> t, n;
  base_signal(5.0, t, n, 5);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] >= 4.2125) n[k] -= 0.03;
  }
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, {}, state_of(t));
  ASSERT_EQ(d.intervals.size(), 1u) << d.message;
  EXPECT_NEAR(d.intervals[0].start_s, 4.2125, 0.005);
  EXPECT_NEAR(d.intervals[0].end_s, 5.0, 0.002);
  EXPECT_NEAR(d.intervals[0].level_v, -0.03, 0.004);
}

TEST(LocateDisturbance, DoesNotLocateWhatTheStateExplains) {
  // A friction-like residual, sign of a 1 Hz velocity times 0.05, over the whole run: spread over
  // half the windows, not a few time windows.
  std::vector<double> t, n;
  base_signal(6.0, t, n, 7);
  for (std::size_t k = 0; k < t.size(); ++k) n[k] += 0.05 * std::tanh(std::cos(kTwoPi * t[k]) / 0.05);
  const DisturbanceEstimate d = locate_disturbance(t, n);
  EXPECT_TRUE(d.ok);
  EXPECT_TRUE(d.intervals.empty()) << d.intervals.size() << " intervals, first at "
                                   << d.intervals.front().start_s;
  EXPECT_FALSE(d.message.empty());
  for (double x : d.d_v) EXPECT_EQ(x, 0.0);
}

TEST(LocateDisturbance, LeavesOutSamplesNotKnownAndSaysWhenTooShort) {
  std::vector<double> t, n;
  base_signal(2.0, t, n, 9);
  std::vector<bool> valid(t.size(), true);
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] >= 0.5 && t[k] < 0.6) n[k] = 1e3, valid[k] = false;  // a one-sided derivative's junk
  }
  const DisturbanceEstimate d = locate_disturbance(t, n, valid);
  EXPECT_TRUE(d.intervals.empty());
  const std::vector<double> short_t(t.begin(), t.begin() + 300), short_n(n.begin(), n.begin() + 300);
  const DisturbanceEstimate s = locate_disturbance(short_t, short_n);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("fewer than 10 windows"), std::string::npos) << s.message;
}

TEST(LocateDisturbance, RefusesBadInputNamingTheField) {
  const std::vector<double> t{0.0, 0.001, 0.002}, n{0.0, 0.0};
  try {
    locate_disturbance(t, std::vector<double>(3, 0.0), {}, {}, {std::vector<double>(2, 0.0)});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "state_basis[0]");
  }
  try {
    locate_disturbance(t, n);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "n_hat_v");
  }
  DisturbanceOptions o;
  o.window_s = 0.0;
  try {
    locate_disturbance(t, std::vector<double>(3, 0.0), {}, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "window_s");
  }
  o = DisturbanceOptions{};
  o.reference_period_s = -0.4;
  try {
    locate_disturbance(t, std::vector<double>(3, 0.0), {}, o);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "reference_period_s");
  }
}

/// 1 kHz samples over 8 s: n̂ = a misfit periodic with a 0.4 s reference (a narrow spike and a
/// ramp each cycle, 0.03 high: no function the caller passes), white noise (0.002), and three
/// pulses of ±0.03 at times no cycle repeats.
void periodic_with_pulses(std::vector<double>& t, std::vector<double>& n, std::vector<double>& truth) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.002);
  for (int k = 0; k < 8000; ++k) {
    const double tk = 1e-3 * k;
    const double phase = std::fmod(tk, 0.4) / 0.4;
    const double misfit = (phase < 0.15 ? 0.03 : 0.0) + 0.02 * (phase - 0.5);
    double d = 0.0;
    if (tk >= 1.13 && tk < 1.23) d = 0.03;
    if (tk >= 3.71 && tk < 3.81) d = -0.03;
    if (tk >= 6.37 && tk < 6.47) d = 0.03;
    t.push_back(tk);
    truth.push_back(d);
    n.push_back(misfit + d + noise(rng));
  }
}

TEST(LocateDisturbance, RemovesWhatRepeatsWithTheReferenceBeforeLocating) {
  std::vector<double> t, n, truth;
  periodic_with_pulses(t, n, truth);
  const double starts[] = {1.13, 3.71, 6.37}, levels[] = {0.03, -0.03, 0.03};
  const auto pulses_found = [&](const DisturbanceEstimate& e) {
    int found = 0;
    for (double s0 : starts) {
      for (const DisturbanceInterval& iv : e.intervals) found += std::abs(iv.start_s - s0) < 0.01;
    }
    return found;
  };
  // Without the reference's period the cycle's spike spreads the window means: the pulses do not
  // all stand out.
  EXPECT_LT(pulses_found(locate_disturbance(t, n)), 3);
  DisturbanceOptions o;
  o.reference_period_s = 0.4;
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, o);
  ASSERT_TRUE(d.ok) << d.message;
  ASSERT_EQ(d.intervals.size(), 3u);
  EXPECT_EQ(pulses_found(d), 3);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(d.intervals[i].start_s, starts[i], 0.01) << i;
    EXPECT_NEAR(d.intervals[i].end_s, starts[i] + 0.1, 0.01) << i;
    EXPECT_NEAR(d.intervals[i].level_v, levels[i], 0.004) << i;
  }
  // A torque that repeats every cycle is the reference's, not a disturbance: with the period, a
  // pulse-free periodic misfit locates nothing.
  std::vector<double> n_periodic(n.size());
  for (std::size_t k = 0; k < n.size(); ++k) n_periodic[k] = n[k] - truth[k];
  EXPECT_TRUE(locate_disturbance(t, n_periodic, {}, o).intervals.empty());
  // Fewer than four cycles: the periodic part is not estimated (too few cycles for a median),
  // the same as without the period.
  std::vector<double> t_short(t.begin(), t.begin() + 1400), n_short(n.begin(), n.begin() + 1400);
  const DisturbanceEstimate s = locate_disturbance(t_short, n_short, {}, o);
  const DisturbanceEstimate s_blind = locate_disturbance(t_short, n_short);
  EXPECT_EQ(s.spread_v, s_blind.spread_v);
  EXPECT_EQ(s.intervals.size(), s_blind.intervals.size());
}

// A torque of position (a cogging of period 0.02 rad, 0.02 high) along a path that is not the same
// each cycle (a 2 Hz sine whose amplitude wanders between 0.06 and 0.14 rad), white noise (0.002)
// and three pulses of ±0.03: neither the state functions nor the reference's period hold the
// cogging; its median at each position does.
TEST(LocateDisturbance, RemovesWhatIsAFunctionOfPositionBeforeLocating) {
  std::mt19937 rng(13);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<double> t, n, theta;
  const double starts[] = {1.37, 3.91, 6.53}, levels[] = {0.03, -0.03, 0.03};
  for (int k = 0; k < 8000; ++k) {
    const double tk = 1e-3 * k;
    const double amplitude = 0.1 + 0.04 * std::sin(kTwoPi * 0.37 * tk);
    const double x = amplitude * std::sin(kTwoPi * 2.0 * tk);
    double d = 0.0;
    for (int i = 0; i < 3; ++i) d += (tk >= starts[i] && tk < starts[i] + 0.1) ? levels[i] : 0.0;
    t.push_back(tk);
    theta.push_back(x);
    n.push_back(0.02 * std::sin(kTwoPi * x / 0.02 + 0.5) + d + noise(rng));
  }
  DisturbanceOptions o;
  o.reference_period_s = 0.5;
  const auto found = [&](const DisturbanceEstimate& e) {
    int hits = 0;
    for (double s0 : starts) {
      for (const DisturbanceInterval& iv : e.intervals) hits += std::abs(iv.start_s - s0) < 0.01;
    }
    return hits;
  };
  const DisturbanceEstimate blind = locate_disturbance(t, n, {}, o);
  EXPECT_LT(found(blind), 3);
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, o, {}, theta);
  ASSERT_TRUE(d.ok) << d.message;
  ASSERT_EQ(d.intervals.size(), 3u) << d.message;
  EXPECT_EQ(found(d), 3);
  EXPECT_TRUE(d.position_part_removed);
  EXPECT_FALSE(blind.position_part_removed);
  EXPECT_LT(d.spread_v, 0.5 * blind.spread_v);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_NEAR(d.intervals[i].start_s, starts[i], 0.01) << i;
    EXPECT_NEAR(d.intervals[i].end_s, starts[i] + 0.1, 0.01) << i;
    EXPECT_NEAR(d.intervals[i].level_v, levels[i], 0.005) << i;
  }
  // Without the pulses, the cogging alone locates nothing.
  std::vector<double> clean(n.size());
  for (std::size_t k = 0; k < n.size(); ++k) {
    double dk = 0.0;
    for (int i = 0; i < 3; ++i) dk += (t[k] >= starts[i] && t[k] < starts[i] + 0.1) ? levels[i] : 0.0;
    clean[k] = n[k] - dk;
  }
  EXPECT_TRUE(locate_disturbance(t, clean, {}, o, {}, theta).intervals.empty());
  // A position series of another length is refused, naming it.
  try {
    locate_disturbance(t, n, {}, o, {}, std::vector<double>(5, 0.0));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "position_rad");
  }
}

// A pulse that pushes the joint where it has not been: θ a 2 Hz sine of 0.1 rad with a wandering
// amplitude (a cogging in n̂ along it), and during a 0.1 s pulse of 0.03 the path is carried 0.05
// rad past its usual top. The pulse's last samples lie in positions not repeated (left out of the
// window means), but its edges and level are taken over every sample: it is located whole.
TEST(LocateDisturbance, LocatesWholeAPulseThatPushesTheJointWhereItHasNotBeen) {
  std::mt19937 rng(19);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<double> t, n, theta;
  const double start = 3.12, level = 0.03;  // the pulse; 3.125 s is a crest of the sine
  for (int k = 0; k < 8000; ++k) {
    const double tk = 1e-3 * k;
    const double amplitude = 0.1 + 0.02 * std::sin(kTwoPi * 0.37 * tk);
    const bool on = tk >= start && tk < start + 0.1;
    const double push = on ? 0.05 * std::sin(kTwoPi * 5.0 * (tk - start)) : 0.0;
    const double x = amplitude * std::sin(kTwoPi * 2.0 * tk) + push;
    t.push_back(tk);
    theta.push_back(x);
    n.push_back(0.02 * std::sin(kTwoPi * x / 0.02 + 0.5) + (on ? level : 0.0) + noise(rng));
  }
  DisturbanceOptions o;
  o.reference_period_s = 0.5;
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, o, {}, theta);
  ASSERT_TRUE(d.ok) << d.message;
  EXPECT_TRUE(d.position_part_removed);
  ASSERT_GE(d.intervals.size(), 1u) << d.message;
  // One interval at the pulse, whole: from its start to its end (any split at a window left out
  // joins end to start).
  double from = 1e9, to = -1e9;
  for (const DisturbanceInterval& iv : d.intervals) {
    EXPECT_GT(iv.start_s, start - 0.02) << iv.start_s;
    EXPECT_LT(iv.end_s, start + 0.12) << iv.end_s;
    EXPECT_NEAR(iv.level_v, level, 0.006) << iv.start_s;
    from = std::min(from, iv.start_s), to = std::max(to, iv.end_s);
  }
  EXPECT_NEAR(from, start, 0.01);
  EXPECT_NEAR(to, start + 0.1, 0.01);
}

// A hold the joint is pushed off: θ jitters about 0 (quantised to 1e-4 rad), and a push of 0.04
// from 2.3 s to 3.1 s moves it to 0.02 rad, a position held nowhere else. The position is not
// repeated enough for its part to be removed (a torque of position and one of time are the same
// thing there): the push is located as without θ.
TEST(LocateDisturbance, KeepsAPushOffAHoldThatNoPositionRepeats) {
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0.0, 0.002), jitter(0.0, 1.5e-4);
  std::vector<double> t, n, theta;
  for (int k = 0; k < 5000; ++k) {
    const double tk = 1e-3 * k;
    const bool pushed = tk >= 2.3 && tk < 3.1;
    t.push_back(tk);
    theta.push_back(1e-4 * std::round(((pushed ? 0.02 : 0.0) + jitter(rng)) / 1e-4));
    n.push_back((pushed ? 0.04 : 0.0) + noise(rng));
  }
  const DisturbanceEstimate d = locate_disturbance(t, n, {}, {}, {}, theta);
  ASSERT_EQ(d.intervals.size(), 1u) << d.message;
  EXPECT_FALSE(d.position_part_removed);
  EXPECT_NEAR(d.intervals[0].start_s, 2.3, 0.005);
  EXPECT_NEAR(d.intervals[0].end_s, 3.1, 0.005);
  EXPECT_NEAR(d.intervals[0].level_v, 0.04, 0.003);
}

// Mirrored half cycles: under a reference of period 1 s (too few cycles in the 3 s for its
// periodic part to be removed), two intervals of opposite sign 0.5 s apart are the model's misfit
// along the reference and are set aside; the same with one sign, or 0.8 s apart, are kept.
TEST(LocateDisturbance, SetsAsideIntervalsOfOppositeSignHalfAPeriodApart) {
  DisturbanceOptions o;
  o.reference_period_s = 1.0;
  const auto with_pair = [&](double second_start, double second_level) {
    std::vector<double> t, n;
    base_signal(3.0, t, n, 5);
    for (std::size_t k = 0; k < t.size(); ++k) {
      if (t[k] >= 1.0005 && t[k] < 1.1005) n[k] += 0.05;
      if (t[k] >= second_start && t[k] < second_start + 0.1) n[k] += second_level;
    }
    return locate_disturbance(t, n, {}, o, state_of(t));
  };
  const DisturbanceEstimate mirrored = with_pair(1.5005, -0.05);
  ASSERT_TRUE(mirrored.ok) << mirrored.message;
  EXPECT_TRUE(mirrored.intervals.empty()) << mirrored.message;
  EXPECT_EQ(mirrored.half_period_pairs_set_aside, 2u);
  EXPECT_DOUBLE_EQ(mirrored.rms_v, 0.0);
  for (double d : mirrored.d_v) ASSERT_EQ(d, 0.0);
  EXPECT_NE(mirrored.message.find("half a reference period"), std::string::npos) << mirrored.message;
  const DisturbanceEstimate one_sign = with_pair(1.5005, 0.05);
  EXPECT_EQ(one_sign.intervals.size(), 2u) << one_sign.message;
  EXPECT_EQ(one_sign.half_period_pairs_set_aside, 0u);
  const DisturbanceEstimate off_the_half = with_pair(1.8005, -0.05);
  EXPECT_EQ(off_the_half.intervals.size(), 2u) << off_the_half.message;
  // Without a periodic reference nothing is set aside.
  o.reference_period_s = 0.0;
  const DisturbanceEstimate plain = with_pair(1.5005, -0.05);
  EXPECT_EQ(plain.intervals.size(), 2u) << plain.message;
}

}  // namespace
}  // namespace alphainv
