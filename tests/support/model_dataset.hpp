#pragma once
// Test support: datasets made by the paper's α-model itself (fixed point + RK4) under the P law
// kp = 2, at given poses: sine runs at `freqs` (±0.07 rad, from θ = 0) and, with `square`, one
// 0.25 Hz square run per pose (from θ = −0.07). Ground truth: paper_linear_model(),
// paper_alpha_model(), and `effects` on the plant. Run files are named
// `file_prefix` + kind + `separator` + (run number from 1).

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/damping_model.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/reference.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv::test {

struct ModelDatasetPlan {
  std::vector<std::pair<double, double>> poses_deg;                      ///< (γ1, γ2) [deg]
  std::vector<double> freqs_hz{1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0};  ///< Table 1
  bool square = true;
  double duration_s = 8.0;
  Effects effects;
  std::string file_prefix, separator;
};

inline void append_model_runs(const ModelDatasetPlan& plan, Dataset& ds, std::vector<RunData>& data) {
  const LinearModel lin = paper_linear_model();
  ds.controller.kp = 2.0;
  for (const auto& [g1, g2] : plan.poses_deg) {
    JointModelAtPose m;
    m.inertia = lin.inertia.inertia(deg_to_rad(g1), deg_to_rad(g2));
    m.c_linear = lin.damping(m.inertia);
    m.beta_tilde_linear = lin.beta_tilde(m.inertia);
    m.alpha = paper_alpha_model();
    m.effects = plan.effects;
    auto add = [&](const Reference& ref, const std::string& kind, double f, double theta0) {
      const auto times = uniform_times(plan.duration_s, 1e-3);
      const SimulationResult s = simulate(m, Controller{}, ref, times, {theta0, 0.0, 0.0});
      ASSERT_TRUE(s.ok);
      RunData d;
      d.t = times;
      for (double t : times) d.r.push_back(ref.at(t).r);
      d.theta = s.theta;
      d.v = s.v;
      data.push_back(d);
      RunInfo run;
      run.file = plan.file_prefix + kind + plan.separator + std::to_string(data.size()) + ".csv";
      run.kind = kind;
      run.freq_hz = f;
      run.amplitude_rad = 0.07;
      run.gamma1_deg = g1;
      run.gamma2_deg = g2;
      run.controller = ds.controller;
      ds.runs.push_back(run);
    };
    for (double f : plan.freqs_hz) add(SineReference(0.07, f), "sine", f, 0.0);
    if (plan.square) add(SquareReference(0.07, 0.25), "square", 0.25, -0.07);
  }
}

}  // namespace alphainv::test
