#include "alphainv/diagnose/verdict.hpp"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

constexpr double kTwoPi = 6.283185307179586476925;

/// A 6 s run at 1 kHz: reference sin(2π f t) (kind "sine") or a square wave of period 4 s
/// ("square"), residual white noise of standard deviation sigma (fixed seed).
ResidualSeries run(const std::string& kind, double f, double sigma, unsigned seed) {
  ResidualSeries s;
  s.name = kind + ".csv";
  s.kind = kind;
  if (kind == "sine") s.freq_hz = f;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma);
  for (int k = 0; k < 6000; ++k) {
    const double t = 0.001 * k;
    s.t.push_back(t);
    s.r.push_back(kind == "sine" ? 0.07 * std::sin(kTwoPi * f * t)
                                 : (std::fmod(t, 4.0) < 2.0 ? 0.05 : -0.05));
    s.residual.push_back(n(rng));
  }
  return s;
}

TEST(Verdict, TheFloorIsTheWhitePartOfTheResidual) {
  // White noise of σ = 1e-4 under a smooth error 50× larger (a slow drift): Δ² sees the noise
  // only (Var Δ²e = 6σ²).
  std::vector<ResidualSeries> runs = {run("sine", 2.0, 1e-4, 1), run("square", 0.0, 1e-4, 2),
                                      run("sine", 5.0, 1e-4, 3)};
  for (std::size_t k = 0; k < runs[1].t.size(); ++k) runs[1].residual[k] += 5e-3 * std::sin(0.5 * runs[1].t[k]);
  const NoiseFloor f = estimate_noise_floor(runs);
  EXPECT_NEAR(f.white, 1e-4, 0.05e-4);
  EXPECT_EQ(f.rms, f.white);
  // The sine runs' steady state, less its harmonics 1…10: the noise, less the 21 of 2500
  // samples' degrees of freedom the fit takes.
  EXPECT_NEAR(f.cycle_to_cycle, 1e-4 * std::sqrt(1.0 - 21.0 / 2500.0), 0.05e-4);
}

TEST(Verdict, WhiteNoiseIsExplained) {
  const std::vector<ResidualSeries> runs = {run("sine", 2.0, 1e-4, 4), run("square", 0.0, 1e-4, 5)};
  const VerdictReport v = judge_residual(runs, estimate_noise_floor(runs));
  EXPECT_EQ(v.verdict, ResidualVerdict::kExplained);
  EXPECT_TRUE(v.unexplained.empty());
  EXPECT_NEAR(v.judged_rms, 1e-4, 0.05e-4);
  EXPECT_EQ(v.text().rfind("explained to the noise floor: judged structure RMS", 0), 0u) << v.text();
  EXPECT_STREQ(verdict_name(v.verdict), "explained");
}

TEST(Verdict, AHarmonicOfTheFundamentalIsStructureAndLocated) {
  // A third harmonic of amplitude 1e-3 (RMS 7.07e-4 = 7× the floor) on the 2 Hz run.
  ResidualSeries s = run("sine", 2.0, 1e-4, 6);
  for (std::size_t k = 0; k < s.t.size(); ++k) s.residual[k] += 1e-3 * std::sin(3.0 * kTwoPi * 2.0 * s.t[k]);
  const HarmonicParts h = harmonic_parts(s, 2.0, 10);
  ASSERT_TRUE(h.ok);
  EXPECT_EQ(h.strongest, 3);
  EXPECT_NEAR(h.harmonics, 1e-3 / std::sqrt(2.0), 0.03e-3);
  EXPECT_NEAR(h.fundamental, 0.0, 0.02e-3);
  EXPECT_NEAR(h.rest, 1e-4, 0.05e-4);
  EXPECT_NEAR(static_cast<double>(h.first), 3499.0, 1.0);  // the last 2.5 s: five whole cycles
  const std::vector<ResidualSeries> runs = {s, run("sine", 5.0, 1e-4, 7)};
  const VerdictReport v = judge_residual(runs, estimate_noise_floor(runs));
  EXPECT_EQ(v.verdict, ResidualVerdict::kStructureRemains);
  ASSERT_EQ(v.unexplained.size(), 1u);
  EXPECT_NE(v.unexplained[0].where.find("sine.csv (2 Hz, steady state)"), std::string::npos);
  EXPECT_NE(v.unexplained[0].where.find("(strongest 3)"), std::string::npos) << v.unexplained[0].where;
  EXPECT_NEAR(v.unexplained[0].ratio, 7.07, 0.5);
  EXPECT_STREQ(verdict_name(v.verdict), "structure_remains");
  // A gain and phase error at the fundamental alone (what C(α), β̃(α) represent) is not judged.
  ResidualSeries g = run("sine", 2.0, 1e-4, 10);
  for (std::size_t k = 0; k < g.t.size(); ++k) g.residual[k] += 3e-3 * std::sin(kTwoPi * 2.0 * g.t[k] + 0.3);
  const std::vector<ResidualSeries> gain = {g, run("sine", 5.0, 1e-4, 11)};
  const VerdictReport two = judge_residual(gain, estimate_noise_floor(gain));
  EXPECT_EQ(two.verdict, ResidualVerdict::kExplained);
  // Two sine runs are too few to judge their fundamentals together.
  EXPECT_TRUE(std::isnan(two.fundamental_median));
  EXPECT_EQ(two.fundamental_runs, 2u);
}

TEST(Verdict, MostSineRunsMissingTheirFundamentalIsStructureOneIsNot) {
  // Four sine runs, white noise σ = 1e-4; a gain and phase error of amplitude 1.5e-3 (RMS
  // 1.06e-3 = 10.6× the floor) in the first three (a level that changes between runs): the
  // median of their errors at the fundamental is one of them.
  const double freqs[] = {1.5, 2.0, 3.0, 5.0};
  std::vector<ResidualSeries> runs;
  for (unsigned i = 0; i < 4; ++i) runs.push_back(run("sine", freqs[i], 1e-4, 20 + i));
  auto add_fundamental = [](ResidualSeries& s, double amplitude, double phase) {
    for (std::size_t k = 0; k < s.t.size(); ++k) s.residual[k] += amplitude * std::sin(kTwoPi * *s.freq_hz * s.t[k] + phase);
  };
  std::vector<ResidualSeries> most = runs;
  for (unsigned i = 0; i < 3; ++i) add_fundamental(most[i], 1.5e-3, 0.7 * i);
  const VerdictReport v = judge_residual(most, estimate_noise_floor(most));
  EXPECT_EQ(v.verdict, ResidualVerdict::kStructureRemains);
  ASSERT_EQ(v.unexplained.size(), 1u);
  EXPECT_NE(v.unexplained[0].where.find("3 of 4 runs miss their gain and phase"), std::string::npos)
      << v.unexplained[0].where;
  EXPECT_NEAR(v.fundamental_median, 1.5e-3 / std::sqrt(2.0), 0.03e-3);
  EXPECT_NEAR(v.unexplained[0].ratio, 10.6, 0.6);
  EXPECT_EQ(v.fundamental_runs_above, 3u);
  EXPECT_EQ(v.fundamental_runs, 4u);
  // One run near a resonance missing it, 30× the floor: the α-model's gain and phase, explained.
  std::vector<ResidualSeries> one = runs;
  add_fundamental(one[2], 4.2e-3, 0.3);
  const VerdictReport w = judge_residual(one, estimate_noise_floor(one));
  EXPECT_EQ(w.verdict, ResidualVerdict::kExplained) << w.text();
  EXPECT_EQ(w.fundamental_runs_above, 1u);
  EXPECT_LT(w.fundamental_median, 1e-5);
  EXPECT_NE(w.text().find("1 of 4 runs above 3× the floor"), std::string::npos) << w.text();
}

TEST(Verdict, OneSineRunNotRepeatingIsSaidNotJudgedMostAreStructure) {
  // Four sine runs, white noise σ = 1e-4. In one, an oscillation at 1.37× the reference
  // frequency (not a harmonic: a slow transient of a lightly damped mode near the resonance),
  // amplitude 2e-3 (RMS 1.41e-3 = 14× the floor): its part that does not repeat is above 3× the
  // floor, the median over the runs is not. Explained, and said: not judged alone.
  const double freqs[] = {1.5, 2.0, 3.0, 5.0};
  std::vector<ResidualSeries> runs;
  for (unsigned i = 0; i < 4; ++i) runs.push_back(run("sine", freqs[i], 1e-4, 40 + i));
  const NoiseFloor white = estimate_noise_floor(runs);
  auto add_mode = [](ResidualSeries& s) {
    for (std::size_t k = 0; k < s.t.size(); ++k) s.residual[k] += 2e-3 * std::sin(kTwoPi * 1.37 * *s.freq_hz * s.t[k]);
  };
  std::vector<ResidualSeries> one = runs;
  add_mode(one[1]);
  const VerdictReport v = judge_residual(one, estimate_noise_floor(one));
  EXPECT_EQ(v.verdict, ResidualVerdict::kExplained) << v.text();
  ASSERT_EQ(v.not_judged.size(), 1u);
  EXPECT_NE(v.not_judged[0].where.find("sine.csv (2 Hz, steady state): error not repeating"), std::string::npos)
      << v.not_judged[0].where;
  EXPECT_NEAR(v.not_judged[0].ratio, 14.2, 1.5);
  EXPECT_NEAR(v.cycle_to_cycle, 1e-4, 0.1e-4);
  EXPECT_NE(v.text().find("not judged alone"), std::string::npos) << v.text();
  EXPECT_NE(v.text().find("1 run above 3× the floor"), std::string::npos) << v.text();
  // The pooled structure is several times the floor: that run is why.
  EXPECT_GT(v.structure_rms, 5.0 * v.floor.rms);
  // In three of the four runs: the median is above 3×, structure remains, and it is judged on
  // the residual given, not on the one the floor was estimated from (white noise only here).
  std::vector<ResidualSeries> most = runs;
  for (unsigned i = 0; i < 3; ++i) add_mode(most[i]);
  const VerdictReport w = judge_residual(most, white);
  EXPECT_EQ(w.verdict, ResidualVerdict::kStructureRemains) << w.text();
  EXPECT_TRUE(w.not_judged.empty());
  EXPECT_NEAR(w.cycle_to_cycle, std::hypot(2e-3 / std::sqrt(2.0), 1e-4), 0.15e-3);
  bool found = false;
  for (const UnexplainedPart& u : w.unexplained)
    found = found || u.where.find("not repeating from cycle to cycle") != std::string::npos;
  EXPECT_TRUE(found) << w.text();
}

TEST(Verdict, TheJudgedStructureLeavesOutTheFundamentalOnly) {
  // A sine run whose residual is a gain error at the fundamental (amplitude 5e-3, not judged), a
  // 2nd harmonic of amplitude 1e-3 and a constant 4e-4 (judged): structure_rms is the RMS of
  // the last two, sqrt((1e-3)²/2 + (4e-4)²), over the steady state; the fundamental alone leaves
  // nothing. A square run's judged samples count whole.
  ResidualSeries s = run("sine", 2.0, 0.0, 7);
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    const double w = kTwoPi * 2.0 * s.t[k];
    s.residual[k] = 5e-3 * std::sin(w + 0.3) + 1e-3 * std::cos(2.0 * w) + 4e-4;
  }
  EXPECT_NEAR(structure_rms({s}), std::sqrt(0.5e-6 + 1.6e-7), 1e-9);
  ResidualSeries only_fundamental = s;
  for (std::size_t k = 0; k < s.t.size(); ++k)
    only_fundamental.residual[k] = 5e-3 * std::sin(kTwoPi * 2.0 * s.t[k] + 0.3);
  EXPECT_LT(structure_rms({only_fundamental}), 1e-12);
  ResidualSeries sq = run("square", 0.0, 0.0, 8);
  for (double& e : sq.residual) e = 2e-4;
  EXPECT_NEAR(structure_rms({sq}), 2e-4, 1e-15);
  // Pooled over the samples of both: between the two.
  const double both = structure_rms({s, sq});
  EXPECT_GT(both, 2e-4);
  EXPECT_LT(both, std::sqrt(0.5e-6 + 1.6e-7));
  EXPECT_TRUE(std::isnan(structure_rms({})));
  // judge_residual() reports it.
  EXPECT_NEAR(judge_residual({s}, estimate_noise_floor({run("sine", 2.0, 1e-4, 9)})).structure_rms,
              std::sqrt(0.5e-6 + 1.6e-7), 1e-9);
}

TEST(Verdict, APulseIsLocatedInTime) {
  // A pulse of 2e-3 from t = 3.0 to 3.3 s on a square run (away from the jumps at 0, 2, 4 s
  // and their transients), as an external force pulse leaves it.
  ResidualSeries s = run("square", 0.0, 1e-4, 8);
  s.kind = "other";
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    if (s.t[k] >= 3.0 && s.t[k] < 3.3) s.residual[k] += 2e-3;
  }
  const std::vector<ResidualSeries> runs = {s};
  const VerdictReport v = judge_residual(runs, estimate_noise_floor(runs));
  EXPECT_EQ(v.verdict, ResidualVerdict::kStructureRemains);
  bool found = false;
  for (const UnexplainedPart& u : v.unexplained) {
    if (u.where.find("t = 3.00–3.40 s") != std::string::npos ||
        u.where.find("t = 3.00–3.20 s") != std::string::npos) {
      found = true;
      EXPECT_GT(u.ratio, 10.0);
    }
  }
  EXPECT_TRUE(found) << v.text();
}

TEST(Verdict, TransientsAfterJumpsAreReportedNotJudged) {
  // An error decaying within 1 s after each jump of the square reference (the α-model's low-α
  // end): not judged, its RMS reported.
  ResidualSeries s = run("square", 0.0, 1e-4, 9);
  for (std::size_t k = 0; k < s.t.size(); ++k) {
    const double since = std::fmod(s.t[k], 2.0);
    s.residual[k] += since < 0.9 ? 5e-3 * std::exp(-since / 0.1) : 0.0;
  }
  const std::vector<ResidualSeries> runs = {s};
  const VerdictReport v = judge_residual(runs, estimate_noise_floor(runs));
  EXPECT_EQ(v.verdict, ResidualVerdict::kExplained) << v.text();
  EXPECT_GT(v.transient_rms, 10.0 * v.judged_rms);
}

TEST(Verdict, NoFloorIsNotAVerdictOfExplained) {
  const VerdictReport v = judge_residual({}, NoiseFloor{});
  EXPECT_EQ(v.verdict, ResidualVerdict::kStructureRemains);
  ASSERT_EQ(v.unexplained.size(), 1u);
  EXPECT_EQ(v.unexplained[0].where, "no noise floor could be estimated from the data");
}

}  // namespace
}  // namespace alphainv
