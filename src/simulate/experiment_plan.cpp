#include "alphainv/simulate/experiment_plan.hpp"

#include <cmath>
#include <set>
#include <utility>

#include "alphainv/error.hpp"
#include "alphainv/simulate/reference.hpp"
#include "common/format.hpp"

namespace alphainv {

namespace {

using common::num;  // "%.6g", the messages' numbers

// --- deterministic hashing (splitmix64)
// -----------------------------------------------------------

std::uint64_t splitmix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

std::uint64_t hash_combine(std::uint64_t h, std::uint64_t v) noexcept {
  return splitmix64(h ^ splitmix64(v));
}

/// A value in micro-units as a hash key (poses and frequencies are given to far less precision).
std::uint64_t key_of(double x) noexcept {
  return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::llround(x * 1e6)));
}

/// Uniform in [0, 1) from the top 53 bits.
double unit_uniform(std::uint64_t h) noexcept {
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

constexpr std::uint64_t kPoseStream = 0x504F5345;   // "POSE"
constexpr std::uint64_t kNoiseStream = 0x4E4F4953;  // "NOIS"
constexpr std::uint64_t kMask53 = (std::uint64_t{1} << 53) - 1;

// --- small JSON writer (the plan's JSON has a fixed shape; the data component owns the parser) ---

std::string json_number(double x) { return std::isfinite(x) ? common::shortest(x) : "null"; }

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char ch : s) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '"' || c == '\\') {
      out += '\\';
      out += ch;
    } else if (c < 0x20) {
      out += common::format("\\u%04x", static_cast<unsigned>(c));
    } else {
      out += ch;
    }
  }
  return out + "\"";
}

/// Builds one JSON object: add("key", raw_json_value) in order.
class JsonObject {
 public:
  JsonObject& raw(const std::string& key, const std::string& value) {
    text_ += (text_.empty() ? "{" : ",") + json_string(key) + ":" + value;
    return *this;
  }
  JsonObject& num(const std::string& key, double x) { return raw(key, json_number(x)); }
  JsonObject& str(const std::string& key, const std::string& s) { return raw(key, json_string(s)); }
  JsonObject& uint(const std::string& key, std::uint64_t x) { return raw(key, std::to_string(x)); }
  JsonObject& boolean(const std::string& key, bool b) { return raw(key, b ? "true" : "false"); }
  std::string text() const { return text_.empty() ? "{}" : text_ + "}"; }

 private:
  std::string text_;
};

template <class It, class F>
std::string json_array(It begin, It end, F&& to_json) {
  std::string out = "[";
  for (It it = begin; it != end; ++it) out += (it == begin ? "" : ",") + to_json(*it);
  return out + "]";
}

std::string num_array(const double* x, std::size_t n) {
  return json_array(x, x + n, [](double v) { return json_number(v); });
}

// --- validation helpers
// ------------------------------------------------------------------------------

void require(bool ok, const std::string& field, const std::string& expected, double got) {
  if (!ok) throw Error("expected " + expected + ", got " + num(got), {}, 0, field);
}

void validate_poses(const std::vector<PoseSetPoint>& poses, const std::string& name) {
  std::set<std::pair<double, double>> seen;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const std::string f = name + "[" + std::to_string(i) + "]";
    require(std::isfinite(poses[i].gamma1_deg), f + ".gamma1_deg", "a finite angle [deg]",
            poses[i].gamma1_deg);
    require(std::isfinite(poses[i].gamma2_deg), f + ".gamma2_deg", "a finite angle [deg]",
            poses[i].gamma2_deg);
    if (!seen.insert({poses[i].gamma1_deg, poses[i].gamma2_deg}).second) {
      throw Error("expected distinct poses, found (" + num(poses[i].gamma1_deg) + ", " +
                      num(poses[i].gamma2_deg) + ") twice",
                  {}, 0, f);
    }
  }
}

/// Re-throws a plant validation error with the field under `prefix` and `context` appended.
void validate_plant(const VirtualOmniParams& p, const std::string& prefix,
                    const std::string& context) {
  try {
    p.validate();
  } catch (const Error& e) {
    throw Error(e.message() + context, {}, 0, prefix + e.field());
  }
}

/// Rounds to 0.01°: the recorded pose is what the plant uses, exactly.
double round_centidegree(double deg) { return std::round(deg * 100.0) / 100.0; }

}  // namespace

std::vector<double> paper_sine_frequencies_hz() {
  return {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0};
}

std::vector<PoseSetPoint> paper_sine_poses() {
  std::vector<PoseSetPoint> out;
  for (double g1 : {25.0, 45.0, 65.0}) {
    for (double g2 : {70.0, 90.0, 115.0}) out.push_back({g1, g2});
  }
  return out;
}

std::vector<PoseSetPoint> paper_square_poses() {
  std::vector<PoseSetPoint> out;
  for (double g1 : {25.0, 35.0, 45.0, 55.0, 65.0}) {
    for (double g2 : {60.0, 70.0, 90.0, 110.0, 115.0}) out.push_back({g1, g2});
  }
  return out;
}

double DisturbancePulses::at(double t_s, std::size_t run_index) const noexcept {
  if (!active() || !(period_s > 0.0)) return 0.0;
  const double golden = 0.6180339887498949;
  const double shift = period_s * std::fmod(golden * static_cast<double>(run_index), 1.0);
  const double since = t_s - first_s - shift;
  if (since < 0.0) return 0.0;
  const double pulse = std::floor(since / period_s);
  if (since - pulse * period_s >= width_s) return 0.0;
  return std::fmod(pulse, 2.0) == 0.0 ? amplitude_v : -amplitude_v;
}

void ExperimentPlanOptions::validate() const {
  validate_plant(plant, "plant.", "");
  {
    const DisturbancePulses& d = disturbance_pulses;
    require(std::isfinite(d.amplitude_v) && d.amplitude_v >= 0.0,
            "disturbance_pulses.amplitude_v", "an amplitude >= 0 [command unit]", d.amplitude_v);
    if (d.active()) {
      require(std::isfinite(d.period_s) && d.period_s > 0.0, "disturbance_pulses.period_s",
              "a period > 0 [s]", d.period_s);
      require(std::isfinite(d.width_s) && d.width_s > 0.0 && d.width_s < d.period_s,
              "disturbance_pulses.width_s", "a width in (0, period_s) [s]", d.width_s);
      require(std::isfinite(d.first_s) && d.first_s >= 0.0, "disturbance_pulses.first_s",
              "a start time >= 0 [s]", d.first_s);
    }
  }
  const double T = plant.tick_period_s;
  const double nyquist = 0.5 / T;
  require(std::isfinite(controller.kp), "controller.kp", "a finite gain", controller.kp);
  require(std::isfinite(controller.ki), "controller.ki", "a finite gain", controller.ki);
  require(std::isfinite(controller.kd), "controller.kd", "a finite gain", controller.kd);
  require(!std::isnan(controller.v_limit) && controller.v_limit > 0.0, "controller.v_limit",
          "a limit > 0 (infinity: none)", controller.v_limit);

  std::set<double> freqs;
  for (std::size_t i = 0; i < sine_freqs_hz.size(); ++i) {
    const std::string f = "sine_freqs_hz[" + std::to_string(i) + "]";
    const double x = sine_freqs_hz[i];
    require(std::isfinite(x) && x > 0.0 && x < nyquist, f,
            "a frequency in (0, " + num(nyquist) + ") Hz", x);
    if (!freqs.insert(x).second)
      throw Error("expected distinct frequencies, found " + num(x) + " twice", {}, 0, f);
  }
  validate_poses(sine_poses, "sine_poses");
  validate_poses(square_poses, "square_poses");
  const bool any_sine = !sine_freqs_hz.empty() && !sine_poses.empty();
  const bool any_square = !square_poses.empty();
  if (!any_sine && !any_square) {
    throw Error("expected at least one run (sine frequencies and poses, or square poses)", {}, 0,
                "sine_poses");
  }
  if (any_sine) {
    require(std::isfinite(sine_amplitude_rad) && sine_amplitude_rad > 0.0, "sine_amplitude_rad",
            "a positive amplitude [rad]", sine_amplitude_rad);
    require(std::isfinite(sine_settle_s) && sine_settle_s >= 0.0, "sine_settle_s",
            "a finite time >= 0 [s]", sine_settle_s);
    require(std::isfinite(sine_steady_s) && sine_steady_s > 0.0, "sine_steady_s",
            "a positive time [s]", sine_steady_s);
  }
  if (any_square) {
    require(std::isfinite(square_freq_hz) && square_freq_hz > 0.0 && square_freq_hz < nyquist,
            "square_freq_hz", "a frequency in (0, " + num(nyquist) + ") Hz", square_freq_hz);
    require(std::isfinite(square_amplitude_rad) && square_amplitude_rad > 0.0,
            "square_amplitude_rad", "a positive amplitude [rad]", square_amplitude_rad);
    require(std::isfinite(square_duration_s) && square_duration_s > 0.0, "square_duration_s",
            "a positive time [s]", square_duration_s);
  }
  const PoseOffsetRange& o = pose_offsets;
  require(std::isfinite(o.gamma1_min_deg), "pose_offsets.gamma1_min_deg", "a finite angle",
          o.gamma1_min_deg);
  require(std::isfinite(o.gamma2_min_deg), "pose_offsets.gamma2_min_deg", "a finite angle",
          o.gamma2_min_deg);
  require(std::isfinite(o.gamma1_max_deg) && o.gamma1_max_deg >= o.gamma1_min_deg,
          "pose_offsets.gamma1_max_deg", "a finite angle >= gamma1_min_deg", o.gamma1_max_deg);
  require(std::isfinite(o.gamma2_max_deg) && o.gamma2_max_deg >= o.gamma2_min_deg,
          "pose_offsets.gamma2_max_deg", "a finite angle >= gamma2_min_deg", o.gamma2_max_deg);
}

ExperimentPlanOptions paper_plan_options(std::uint64_t seed) {
  ExperimentPlanOptions o;
  o.seed = seed;
  o.plant.effects.coulomb_v = 0.004;
  o.plant.effects.coulomb_smoothing_rad_s = 1e-3;
  o.plant.measurement.quantisation_rad = 1.5e-4;
  o.plant.measurement.noise_std_rad = 5e-5;
  return o;
}

ExperimentPlan make_experiment_plan(const ExperimentPlanOptions& options) {
  options.validate();
  ExperimentPlan plan;
  plan.options = options;
  const double T = options.plant.tick_period_s;

  // Distinct poses: the sine poses, then the square-only ones. True angles from (seed, set pose).
  auto pose_index = [&](const PoseSetPoint& set) {
    for (std::size_t i = 0; i < plan.poses.size(); ++i) {
      if (plan.poses[i].gamma1_set_deg == set.gamma1_deg &&
          plan.poses[i].gamma2_set_deg == set.gamma2_deg) {
        return i;
      }
    }
    const PoseOffsetRange& o = options.pose_offsets;
    const std::uint64_t key =
        hash_combine(hash_combine(hash_combine(options.seed, kPoseStream), key_of(set.gamma1_deg)),
                     key_of(set.gamma2_deg));
    PlannedPose p;
    p.gamma1_set_deg = set.gamma1_deg;
    p.gamma2_set_deg = set.gamma2_deg;
    p.gamma1_deg = round_centidegree(set.gamma1_deg + o.gamma1_min_deg +
                                     (o.gamma1_max_deg - o.gamma1_min_deg) *
                                         unit_uniform(hash_combine(key, 1)));
    p.gamma2_deg = round_centidegree(set.gamma2_deg + o.gamma2_min_deg +
                                     (o.gamma2_max_deg - o.gamma2_min_deg) *
                                         unit_uniform(hash_combine(key, 2)));
    VirtualOmniParams at_pose = options.plant;
    at_pose.gamma1_deg = p.gamma1_deg;
    at_pose.gamma2_deg = p.gamma2_deg;
    validate_plant(at_pose, "plant.",
                   " (at the true pose " + num(p.gamma1_deg) + ", " + num(p.gamma2_deg) +
                       " deg of the set point " + num(set.gamma1_deg) + ", " + num(set.gamma2_deg) +
                       ")");
    p.inertia = options.plant.inertia.inertia(deg_to_rad(p.gamma1_deg), deg_to_rad(p.gamma2_deg));
    plan.poses.push_back(p);
    return plan.poses.size() - 1;
  };
  auto noise_seed = [&](std::uint64_t kind, const PoseSetPoint& set, double freq_hz) {
    std::uint64_t h = hash_combine(hash_combine(options.seed, kNoiseStream), kind);
    h = hash_combine(hash_combine(hash_combine(h, key_of(set.gamma1_deg)), key_of(set.gamma2_deg)),
                     key_of(freq_hz));
    return h & kMask53;
  };

  if (!options.sine_freqs_hz.empty()) {
    for (const PoseSetPoint& set : options.sine_poses) {
      const std::size_t pose = pose_index(set);
      for (const double f : options.sine_freqs_hz) {
        PlannedRun run;
        run.kind = "sine";
        run.file = "runs/sine_" + num(set.gamma1_deg) + "_" + num(set.gamma2_deg) +
                   "_" + num(f) + "hz.csv";
        run.freq_hz = f;
        run.amplitude_rad = options.sine_amplitude_rad;
        const double periods = std::max(1.0, std::ceil(options.sine_steady_s * f - 1e-9));
        run.duration_s = options.sine_settle_s + periods / f;
        run.steady_state_start_s = options.sine_settle_s;
        run.initial_theta_rad = 0.0;
        run.pose = pose;
        run.noise_seed = noise_seed(1, set, f);
        plan.runs.push_back(run);
      }
    }
  }
  for (const PoseSetPoint& set : options.square_poses) {
    PlannedRun run;
    run.kind = "square";
    run.file =
        "runs/square_" + num(set.gamma1_deg) + "_" + num(set.gamma2_deg) + ".csv";
    run.freq_hz = options.square_freq_hz;
    run.amplitude_rad = options.square_amplitude_rad;
    run.duration_s = options.square_duration_s;
    run.steady_state_start_s = 0.0;
    run.initial_theta_rad = -options.square_amplitude_rad;  // θ(0⁻) = −A, eq. (47)
    run.pose = pose_index(set);
    run.noise_seed = noise_seed(2, set, options.square_freq_hz);
    plan.runs.push_back(run);
  }
  for (const PlannedRun& run : plan.runs) {
    if (std::round(run.duration_s / T) > 1e8) {
      throw Error("expected at most 1e8 samples per run, got " + num(run.duration_s / T), {}, 0,
                  run.kind == "sine" ? "sine_steady_s" : "square_duration_s");
    }
  }
  return plan;
}

ExperimentPlan paper_experiment_plan(std::uint64_t seed) {
  return make_experiment_plan(paper_plan_options(seed));
}

VirtualOmniParams planned_plant(const ExperimentPlan& plan, std::size_t i) {
  if (i >= plan.runs.size()) {
    throw Error(
        "expected a run index < " + std::to_string(plan.runs.size()) + ", got " + std::to_string(i),
        {}, 0, "runs");
  }
  const PlannedRun& run = plan.runs[i];
  const PlannedPose& pose = plan.poses.at(run.pose);
  VirtualOmniParams p = plan.options.plant;
  p.gamma1_deg = pose.gamma1_deg;
  p.gamma2_deg = pose.gamma2_deg;
  p.initial_theta_rad = run.initial_theta_rad;
  p.initial_theta_dot_rad_s = 0.0;
  p.measurement.seed = run.noise_seed;
  return p;
}

RunData simulate_planned_run(const ExperimentPlan& plan, std::size_t i) {
  VirtualOmni omni(planned_plant(plan, i));
  const PlannedRun& run = plan.runs[i];
  ClosedLoopOptions opt;
  opt.record_truth = plan.options.record_truth_columns;
  if (plan.options.disturbance_pulses.active()) {
    const DisturbancePulses pulses = plan.options.disturbance_pulses;
    opt.disturbance_v = [pulses, i](double t) { return pulses.at(t, i); };
  }
  if (plan.options.invented.active()) opt.hidden_torque_v = invented_torque(plan.options.invented, i);
  if (run.kind == "sine") {
    const SineReference ref(run.amplitude_rad, run.freq_hz);
    return run_closed_loop(omni, plan.options.controller, ref, run.duration_s, opt);
  }
  const SquareReference ref(run.amplitude_rad, run.freq_hz);
  return run_closed_loop(omni, plan.options.controller, ref, run.duration_s, opt);
}

std::string truth_json(const ExperimentPlan& plan) {
  const ExperimentPlanOptions& o = plan.options;
  const VirtualOmniParams& p = o.plant;
  const Effects& e = p.effects;
  const AlphaModel& a = p.alpha_model;

  JsonObject inertia;
  inertia.num("i_base", p.inertia.i_base)
      .num("i1", p.inertia.i1)
      .num("i2", p.inertia.i2)
      .num("i3", p.inertia.i3)
      .num("gamma_offs_rad", p.inertia.gamma_offs_rad)
      .num("gamma_offs_deg", rad_to_deg(p.inertia.gamma_offs_rad))
      .str("equation",
           "I = i_base + i1 cos^2(g1) + i2 cos^2(psi) + i3 cos(g1) cos(psi), "
           "psi = pi - g1 - g2 - gamma_offs, eq. (6)");
  JsonObject alpha_model;
  alpha_model.raw("alpha", num_array(a.alpha.data(), a.n_breakpoints))
      .raw("c_n1", num_array(a.c_n1.data(), a.n_breakpoints))
      .raw("beta_alpha", num_array(a.beta_alpha.data(), 2))
      .raw("beta_n1", num_array(a.beta_n1.data(), 2))
      .str("equation",
           "C_n(I) = 1/(c_n1 I) at alpha_n, linear between, held outside, eqs. "
           "(38)-(40); beta~_n(I) = 1/(beta_n1 I) at beta_alpha_n, eqs. (41)-(42)");
  JsonObject filter;
  filter
      .str("kind",
           "3rd-order Butterworth, state-variable form, first-order hold "
           "(rt::AlphaEstimator), fed the tick-average of v_eff once per tick; alpha = "
           "w'^2 - w w''")
      .num("cutoff_hz", p.alpha_filter.cutoff_hz)
      .num("sample_period_s", p.alpha_filter.sample_period_s);
  JsonObject effects;
  effects
      .str("equation",
           "theta'' + C(alpha,I) theta' = beta~(alpha,I) (v_eff(t) + n), n = "
           "-coulomb_v tanh(theta'/coulomb_smoothing_rad_s) + offset_v - gravity_v "
           "sin(theta + gravity_theta0_rad) + cogging_v sin(2 pi theta / "
           "cogging_period_rad + cogging_phase_rad); v_eff = clamp(deadzone(v(t - "
           "delay_s)), +-saturation_v); 0 (null for saturation_v) = off")
;
  for (const EffectSpec& spec : kEffectCatalogue) {
    for (const EffectParameter& par : spec) effects.num(par.name, e.*par.member);
  }
  JsonObject measurement;
  measurement.num("quantisation_rad", p.measurement.quantisation_rad)
      .num("noise_std_rad", p.measurement.noise_std_rad)
      .str("equation",
           "theta_meas = q round((theta + w)/q), w ~ N(0, noise_std^2), "
           "mt19937_64 seeded per run (runs[i].truth.noise_seed), Box-Muller");
  JsonObject offsets;
  const double g1_range[2] = {o.pose_offsets.gamma1_min_deg, o.pose_offsets.gamma1_max_deg};
  const double g2_range[2] = {o.pose_offsets.gamma2_min_deg, o.pose_offsets.gamma2_max_deg};
  offsets.raw("gamma1", num_array(g1_range, 2))
      .raw("gamma2", num_array(g2_range, 2))
      .str("note",
           "true - set pose [deg], uniform per pose from the seed, rounded to 0.01 deg; "
           "gamma1_deg/gamma2_deg of each run are the true (measured) pose");
  JsonObject controller;
  controller.str("implementation",
                 "digital PID at every tick: v_k = clamp(kp e_k + ki sum(T e_j, j<=k) + kd "
                 "(e_k - e_k-1)/T), e_k = r(t_k) - theta_meas(t_k), held over [t_k, t_k + T) "
                 "(zero-order hold; no anti-windup)");
  JsonObject truth;
  truth.str("plant", "alphainv::VirtualOmni")
      .uint("seed", o.seed)
      .num("tick_period_s", p.tick_period_s)
      .raw("rk4_substeps", std::to_string(p.substeps))
      .num("initial_command_v", p.initial_command_v)
      .raw("inertia_model", inertia.text())
      .raw("alpha_model", alpha_model.text())
      .raw("alpha_filter", filter.text())
      .raw("effects", effects.text())
      .raw("measurement", measurement.text())
      .raw("pose_offsets_deg", offsets.text())
      .raw("controller", controller.text());
  if (o.disturbance_pulses.active()) {
    const DisturbancePulses& d = o.disturbance_pulses;
    JsonObject pulses;
    pulses.num("amplitude_v", d.amplitude_v)
        .num("width_s", d.width_s)
        .num("period_s", d.period_s)
        .num("first_s", d.first_s)
        .str("equation",
             "d(t) = +-amplitude_v (alternating, + first) for width_s every period_s from first_s "
             "+ frac(0.618 i) period_s (run i); added to n, recorded as disturbance_v");
    truth.raw("disturbance_pulses", pulses.text());
  }
  // An invented effect (invented_effects.hpp): not recorded in the runs, said here.
  if (o.invented.active()) truth.str("invented_effect", o.invented.text());
  return truth.text();
}

Dataset plan_dataset_index(const ExperimentPlan& plan) {
  const ExperimentPlanOptions& o = plan.options;
  Dataset ds;
  ds.joint = o.joint;
  ds.position_unit = "rad";
  ds.command_unit = "V";
  ds.sample_rate_hz = 1.0 / o.plant.tick_period_s;
  ds.controller = o.controller;
  JsonObject extra;
  extra.str("source", "alphainv virtual Omni, seed " + std::to_string(o.seed));
  if (!o.generator_command.empty()) extra.str("generator", o.generator_command);
  extra.raw("truth", truth_json(plan));
  ds.extra_json = extra.text();

  const AlphaModel& a = o.plant.alpha_model;
  for (const PlannedRun& run : plan.runs) {
    const PlannedPose& pose = plan.poses.at(run.pose);
    RunInfo info;
    info.file = run.file;
    info.kind = run.kind;
    info.freq_hz = run.freq_hz;
    info.amplitude_rad = run.amplitude_rad;
    info.gamma1_deg = pose.gamma1_deg;
    info.gamma2_deg = pose.gamma2_deg;
    info.controller = ds.controller;
    double c[kMaxBreakpoints] = {};
    for (std::size_t n = 0; n < a.n_breakpoints; ++n) c[n] = a.damping(a.alpha[n], pose.inertia);
    const double bt[2] = {a.beta_tilde(a.beta_alpha[0], pose.inertia),
                          a.beta_tilde(a.beta_alpha[1], pose.inertia)};
    JsonObject truth;
    truth.num("inertia", pose.inertia)
        .raw("c_at_alpha", num_array(c, a.n_breakpoints))
        .raw("beta_tilde_at_beta_alpha", num_array(bt, 2))
        .num("initial_theta_rad", run.initial_theta_rad)
        .uint("noise_seed", run.noise_seed);
    JsonObject extra_run;
    extra_run.num("gamma1_set_deg", pose.gamma1_set_deg)
        .num("gamma2_set_deg", pose.gamma2_set_deg)
        .num("duration_s", run.duration_s)
        .num("steady_state_start_s", run.steady_state_start_s)
        .raw("truth", truth.text());
    info.extra_json = extra_run.text();
    ds.runs.push_back(std::move(info));
  }
  return ds;
}

GeneratedDataset generate_dataset(const ExperimentPlan& plan) {
  GeneratedDataset out;
  out.index = plan_dataset_index(plan);
  out.runs.reserve(plan.runs.size());
  for (std::size_t i = 0; i < plan.runs.size(); ++i)
    out.runs.push_back(simulate_planned_run(plan, i));
  return out;
}

}  // namespace alphainv
