#include "alphainv/simulate/model_simulation.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>

#include "alphainv/error.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "common/format.hpp"

namespace alphainv {

namespace {

using common::num;  // "%.6g", the messages' numbers

void require_positive(double x, const char* field, const char* unit) {
  if (!std::isfinite(x) || !(x > 0.0)) {
    throw Error(std::string("expected a finite number > 0 [") + unit + "], got " + num(x), {}, 0,
                field);
  }
}

}  // namespace

JointModelAtPose model_at(const ModelFile& model, std::optional<double> gamma1_deg,
                          std::optional<double> gamma2_deg, bool use_alpha, std::string* note) {
  if (gamma1_deg.has_value() != gamma2_deg.has_value()) {
    throw Error("give both pose angles or neither", {}, 0,
                gamma1_deg ? "gamma2_deg" : "gamma1_deg");
  }
  if (use_alpha && !model.has_alpha_model) {
    throw Error("the model has no alpha-invariant model (use the linear model)", {}, 0,
                "alpha_model");
  }
  JointModelAtPose m;
  m.use_alpha = use_alpha;
  m.alpha = model.alpha;
  m.effects = model.effects;
  std::string said;
  if (model.has_inertia_model) {
    if (!gamma1_deg) {
      throw Error("the model has an inertia model: the pose (gamma1, gamma2) is needed", {}, 0,
                  "gamma1_deg");
    }
    if (!std::isfinite(*gamma1_deg) || !std::isfinite(*gamma2_deg)) {
      throw Error("expected finite pose angles [deg]", {}, 0, "gamma1_deg");
    }
    // eq. (6) at the pose, then (24)-(25).
    m = model_at_pose(model.linear, model.alpha, deg_to_rad(*gamma1_deg), deg_to_rad(*gamma2_deg),
                      use_alpha);
    m.effects = model.effects;
    if (!(m.inertia > 0.0)) {
      throw Error("the inertia model gives I = " + num(m.inertia) + " <= 0 at this pose", {}, 0,
                  "inertia_model");
    }
    said = "inertia model (6) at gamma1 = " + num(*gamma1_deg) +
           " deg, gamma2 = " + num(*gamma2_deg) + " deg: I = " + num(m.inertia);
  } else {
    if (model.poses.empty()) {
      throw Error("the model has neither an inertia model nor a per-pose linear model", {}, 0,
                  "poses");
    }
    std::size_t best = 0;
    if (model.poses.size() > 1) {
      if (!gamma1_deg) {
        throw Error("the model has " + std::to_string(model.poses.size()) +
                        " per-pose linear models: the pose (gamma1, gamma2) is needed to choose",
                    {}, 0, "gamma1_deg");
      }
      double best_d2 = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < model.poses.size(); ++k) {
        const PoseLinearModel& p = model.poses[k];
        if (!p.gamma1_deg || !p.gamma2_deg) continue;
        const double d1 = *p.gamma1_deg - *gamma1_deg, d2 = *p.gamma2_deg - *gamma2_deg;
        if (d1 * d1 + d2 * d2 < best_d2) {
          best_d2 = d1 * d1 + d2 * d2;
          best = k;
        }
      }
      if (!std::isfinite(best_d2)) {
        throw Error("none of the per-pose linear models has known pose angles", {}, 0, "poses");
      }
    }
    const PoseLinearModel& p = model.poses[best];
    if (!(p.c_linear > 0.0) || !(p.beta_tilde_linear > 0.0)) {
      throw Error("expected C_linear > 0 and beta_tilde_linear > 0", {}, 0,
                  "poses[" + std::to_string(best) + "]");
    }
    m.inertia = 1.0;  // per-pose models: C_n1 = 1/C_n at the pose (fit_pipeline)
    m.c_linear = p.c_linear;
    m.beta_tilde_linear = p.beta_tilde_linear;
    const std::string at = p.gamma1_deg && p.gamma2_deg
                               ? num(*p.gamma1_deg) + "/" + num(*p.gamma2_deg) + " deg"
                               : "pose angles unknown";
    said = std::string("no inertia model: the linear model of ") +
           (model.poses.size() > 1 ? "the nearest pose, " : "the only pose, ") + at + " (poses[" +
           std::to_string(best) + "])";
  }
  if (note) *note = said + (use_alpha ? ", alpha-invariant model" : ", linear model");
  return m;
}

ModelRun simulate_model_run(const ModelFile& model, const JointModelAtPose& joint,
                            const ModelRunOptions& o, std::optional<double> gamma1_deg,
                            std::optional<double> gamma2_deg) {
  require_positive(o.freq_hz, "freq_hz", "Hz");
  require_positive(o.amplitude_rad, "amplitude_rad", "position unit");
  require_positive(o.duration_s, "duration_s", "s");
  require_positive(o.sample_rate_hz, "sample_rate_hz", "Hz");
  if (o.kp) require_positive(*o.kp, "kp", "command unit/position unit");
  if (o.duration_s * o.sample_rate_hz > 5e7) {
    throw Error("more than 5e7 samples (duration_s * sample_rate_hz)", {}, 0, "duration_s");
  }

  ModelRun run;
  run.controller = model.controller;
  if (o.kp) run.controller.kp = *o.kp;
  run.simulation = o.simulation;
  run.simulation.loop_period_s = model.loop_period_s;

  const bool sine = o.reference == ModelRunReference::kSine;
  std::unique_ptr<Reference> ref;
  InitialState x0;
  if (sine) {
    ref = std::make_unique<SineReference>(o.amplitude_rad, o.freq_hz);
  } else {
    ref = std::make_unique<SquareReference>(o.amplitude_rad, o.freq_hz);
    x0.theta = -o.amplitude_rad;  // the paper's step runs start at the low level
  }
  const std::vector<double> times = uniform_times(o.duration_s, 1.0 / o.sample_rate_hz);
  const KnownInputSeries known =
      o.known_inputs != nullptr ? KnownInputSeries::of_run(*o.known_inputs) : KnownInputSeries{};
  const SimulationResult s =
      simulate(joint, run.controller, *ref, times, x0, run.simulation, known);

  run.info.kind = sine ? "sine" : "square";
  run.info.file = "runs/" + run.info.kind + "_" + num(o.freq_hz) + "hz.csv";
  run.info.freq_hz = o.freq_hz;
  run.info.amplitude_rad = o.amplitude_rad;
  run.info.gamma1_deg = gamma1_deg;
  run.info.gamma2_deg = gamma2_deg;
  run.info.controller = run.controller;
  run.message = s.message;
  if (!s.ok) return run;

  RunData& d = run.data;
  d.t = s.t;
  d.r.resize(s.t.size());
  for (std::size_t k = 0; k < s.t.size(); ++k) d.r[k] = ref->at(s.t[k]).r;
  d.theta = s.theta;
  d.v = s.v;
  d.extra_columns["alpha"] = s.alpha;
  d.extra_columns["C"] = s.damping;
  d.extra_columns["beta_tilde"] = s.beta_tilde;
  d.extra_columns["theta_dot"] = s.theta_dot;
  if (!known.empty()) {
    std::vector<double> dist, enable, offset;
    for (double t : s.t) {
      const KnownInputs k = known.at(t);
      dist.push_back(k.disturbance_v);
      enable.push_back(k.torque_enabled ? 1.0 : 0.0);
      offset.push_back(k.command_offset_v);
    }
    if (known.has_disturbance()) d.extra_columns["disturbance_v"] = std::move(dist);
    if (known.has_torque_enable()) d.extra_columns["torque_enable"] = std::move(enable);
    if (known.has_command_offset()) d.extra_columns["v_comp"] = std::move(offset);
  }
  for (const auto& [name, col] : d.extra_columns) {
    for (double x : col) {
      if (!std::isfinite(x)) {
        run.data = RunData{};
        run.message = "the simulation gave a non-finite " + name;
        return run;
      }
    }
  }
  run.ok = true;
  return run;
}

Dataset model_run_dataset(const ModelFile& model, const ModelRun& run, double sample_rate_hz) {
  Dataset ds;
  ds.position_unit = model.position_unit;
  ds.command_unit = model.command_unit;
  ds.sample_rate_hz = sample_rate_hz;
  ds.controller = run.info.controller;
  ds.runs.push_back(run.info);
  ds.extra_json = R"js({"source": "omni_fit simulate (alphainv model_simulation)"})js";
  return ds;
}

}  // namespace alphainv
