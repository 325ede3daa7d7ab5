#include "sweep_command.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "plots.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;

/// One generated case.
struct SweepCase {
  EffectKind effect = EffectKind::kNone;
  double magnitude = 0.0;  ///< the effect's main parameter (see apply)
  double noise_std_rad = 5e-5;
  std::uint64_t seed = 1;
  /// --vary: the magnitude's factor and the other parameters (cogging period and phase, gravity
  /// θ0), drawn from the seed; otherwise factor 1, period 0.02 rad, phase 0.5 rad, θ0 = 0.
  double factor = 1.0, cogging_period_rad = 0.02, cogging_phase_rad = 0.5, gravity_theta0_rad = 0.0;
};

/// The --vary draws of a case (deterministic in the seed and the effect).
void draw_variation(SweepCase& c) {
  std::mt19937_64 rng(c.seed * 1315423911u + static_cast<std::uint64_t>(c.effect) * 2654435761u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  c.factor = std::exp(std::log(0.6) + u(rng) * (std::log(1.6) - std::log(0.6)));  // 0.6 … 1.6
  c.cogging_period_rad = 0.012 + u(rng) * 0.018;  // 0.012 … 0.03 rad: 5 … 12 periods over ±0.07
  c.cogging_phase_rad = -3.14159 + u(rng) * 6.28318;
  c.gravity_theta0_rad = -0.5 + u(rng) * 1.0;
}

/// The hidden effect's main parameter: the magnitude times the factor (a larger factor is a
/// stronger effect: for a saturation, a lower limit).
double hidden_magnitude(const SweepCase& c) {
  return c.effect == EffectKind::kSaturation ? c.magnitude / c.factor : c.magnitude * c.factor;
}

/// Sets the hidden effect on the plant. Magnitudes are in the plant's units (V, s, rad).
void apply(const SweepCase& c, Effects& e) {
  const double m = hidden_magnitude(c);
  switch (c.effect) {
    case EffectKind::kNone: break;
    case EffectKind::kCoulombFriction: e.coulomb_v = m; break;
    case EffectKind::kOffsetTorque: e.offset_v = m; break;
    case EffectKind::kGravity:
      e.gravity_v = m;
      e.gravity_theta0_rad = c.gravity_theta0_rad;
      break;
    case EffectKind::kCogging:
      e.cogging_v = m;
      e.cogging_period_rad = c.cogging_period_rad;
      e.cogging_phase_rad = c.cogging_phase_rad;
      break;
    case EffectKind::kTimeDelay: e.delay_s = m; break;
    case EffectKind::kSaturation: e.saturation_v = m; break;
    case EffectKind::kDeadzone: e.deadzone_v = m; break;
  }
}

/// Two magnitudes per effect: clearly visible, and about half of that.
std::vector<double> magnitudes(EffectKind k) {
  switch (k) {
    case EffectKind::kCoulombFriction: return {0.02, 0.01};
    case EffectKind::kOffsetTorque: return {0.02, 0.01};
    case EffectKind::kGravity: return {0.3, 0.15};
    case EffectKind::kCogging: return {0.02, 0.01};
    case EffectKind::kTimeDelay: return {0.004, 0.002};
    case EffectKind::kSaturation: return {0.12, 0.2};
    case EffectKind::kDeadzone: return {0.01, 0.005};
    case EffectKind::kNone: return {0.0};
  }
  return {0.0};
}

}  // namespace

CLI::App* add_sweep_subcommand(CLI::App& app, SweepCommandOptions& o) {
  auto* c = app.add_subcommand(
      "sweep", "diagnose generated datasets with one hidden effect each; print the confusion matrix");
  c->add_option("--seeds", o.seeds, "seeds (pose, noise) of the generated datasets")->capture_default_str();
  c->add_option("--effects", o.effects, "hidden effects to generate (catalogue names, none); default all");
  c->add_flag("--quick", o.quick, "one magnitude and one noise level per effect");
  c->add_flag("--vary", o.vary,
              "draw from each seed a factor 0.6-1.6 on the magnitude and the effect's other "
              "parameters (cogging period 0.012-0.03 rad and phase, gravity theta0 within "
              "+-0.5 rad); default: fixed ones");
  c->add_flag("--require", o.require,
              "exit 1 unless every case names its effect (cutting the RMS error by >= 30 %) and "
              "every effect-free case says none");
  c->add_flag("--json", o.json, "print the cases as one JSON object");
  c->add_option("--threads", o.threads, "threads (default: all cores)");
  c->add_option("-o,--out", o.out_file, "write the confusion matrix (Markdown) to this file");
  c->footer("Each case: the paper's 9-frequency sine sweep and a 0.25 Hz square wave at one pose "
            "(10 runs, 1 kHz, kp = 2, encoder quantisation 1.5e-4 rad, noise as listed), one "
            "hidden effect at two magnitudes, then `diagnose` from the data alone.\n"
            "Examples:\n  omni_fit sweep --seeds 1 2 -o docs/diagnose-sweep.md\n"
            "  omni_fit sweep --quick --effects none offset_torque --require");
  return c;
}

int run_sweep(const SweepCommandOptions& o) {
  std::vector<EffectKind> kinds;
  try {
    for (const auto& n : o.effects) kinds.push_back(effect_kind_from_name(n, "--effects"));
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit sweep: %s\n", e.what());
    return 1;
  }
  if (kinds.empty()) kinds.assign(kAllEffectKinds.begin(), kAllEffectKinds.end());
  const std::vector<double> noises = o.quick ? std::vector<double>{5e-5} : std::vector<double>{5e-5, 2e-4};
  std::vector<SweepCase> cases;
  for (EffectKind k : kinds) {
    std::vector<double> mags = magnitudes(k);
    if (o.quick) mags.resize(1);
    // `none` gets as many cases as one effect with two magnitudes.
    const int repeat = (k == EffectKind::kNone && !o.quick) ? 2 : 1;
    for (std::uint64_t seed : o.seeds)
      for (double noise : noises)
        for (double m : mags)
          for (int r = 0; r < repeat; ++r)
            cases.push_back({k, m, noise, seed + 1000u * static_cast<std::uint64_t>(r)});
  }
  if (o.vary) {
    for (SweepCase& c : cases) draw_variation(c);
  }
  std::map<std::pair<int, int>, int> matrix;  // (true, named) → count
  int right = 0, named_effect = 0, cut_ok = 0, none_cases = 0, none_right = 0;
  nlohmann::json jcases = nlohmann::json::array();
  const auto t0 = std::chrono::steady_clock::now();
  for (std::size_t ci = 0; ci < cases.size(); ++ci) {
    const SweepCase& c = cases[ci];
    ExperimentPlanOptions plan = paper_plan_options(c.seed);
    plan.plant.effects.coulomb_v = 0.0;  // only the hidden effect
    apply(c, plan.plant.effects);
    plan.plant.measurement.noise_std_rad = c.noise_std_rad;
    const auto poses = paper_sine_poses();
    const PoseSetPoint pose = poses[static_cast<std::size_t>(c.seed % poses.size())];
    plan.sine_poses = {pose};
    plan.square_poses = {pose};
    const GeneratedDataset gen = generate_dataset(make_experiment_plan(plan));
    DiagnoseOptions dopt;
    dopt.threads = o.threads;
    const DiagnoseResult r = diagnose_dataset(gen.index, gen.runs, dopt);
    const EffectKind named = r.ok && !r.effects_named.empty() ? r.effects_named.front() : EffectKind::kNone;
    const double cut = r.error_before > 0 ? 1.0 - r.error_after / r.error_before : 0.0;
    ++matrix[{static_cast<int>(c.effect), static_cast<int>(named)}];
    const bool ok_name = named == c.effect;
    right += ok_name;
    if (c.effect == EffectKind::kNone) {
      ++none_cases;
      none_right += ok_name;
    }
    if (named != EffectKind::kNone) {
      ++named_effect;
      cut_ok += cut >= 0.30;
    }
    const double magnitude = hidden_magnitude(c);
    std::fprintf(stderr, "[%zu/%zu] %-16s %-8.3g noise %.0e seed %llu -> %-16s RMS %.3g -> %.3g (%.0f %%) %.1f s%s\n",
                 ci + 1, cases.size(), effect_name(c.effect), magnitude, c.noise_std_rad,
                 static_cast<unsigned long long>(c.seed), effect_name(named), r.error_before,
                 r.error_after, 100.0 * cut, r.seconds, ok_name ? "" : "  WRONG");
    Effects hidden;
    apply(c, hidden);
    // The same dataset from the command line (omni_gen), to look at one case closely.
    std::ostringstream gen_cmd;
    gen_cmd.precision(6);
    gen_cmd << "omni_gen paper -o DIR --seed " << c.seed << " --pose " << c.seed % poses.size()
            << (hidden.coulomb_v > 0.0 ? "" : " --no-coulomb") << " --noise-std " << c.noise_std_rad;
    const std::pair<const char*, double> gen_effects[] = {
        {"offset", hidden.offset_v}, {"gravity", hidden.gravity_v},
        {"gravity_theta0", hidden.gravity_theta0_rad}, {"cogging", hidden.cogging_v},
        {"cogging_period", hidden.cogging_v != 0.0 ? hidden.cogging_period_rad : 0.0},
        {"cogging_phase", hidden.cogging_v != 0.0 ? hidden.cogging_phase_rad : 0.0},
        {"coulomb", hidden.coulomb_v}, {"delay", hidden.delay_s}, {"deadzone", hidden.deadzone_v},
        {"saturation", std::isfinite(hidden.saturation_v) ? hidden.saturation_v : 0.0}};
    for (const auto& [name, x] : gen_effects) {
      if (x != 0.0) gen_cmd << " --effect " << name << "=" << x;
    }
    jcases.push_back({{"effect", effect_name(c.effect)}, {"magnitude", magnitude},
                      {"hidden", effects_text(hidden)}, {"generate", gen_cmd.str()},
                      {"noise_std_rad", c.noise_std_rad}, {"seed", c.seed},
                      {"named", effect_name(named)}, {"error_before", r.error_before},
                      {"error_after", r.error_after}, {"seconds", r.seconds}});
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // The matrix.
  std::ostringstream md;
  md << "Confusion matrix of `omni_fit diagnose` on generated datasets (rows: hidden effect; "
        "columns: effect named). "
     << cases.size() << " cases, seeds";
  for (auto s : o.seeds) md << " " << s;
  md << ", " << (o.quick ? "one magnitude, noise 5e-5 rad" : "two magnitudes, noise 5e-5 and 2e-4 rad")
     << (o.vary ? ", magnitudes × 0.6-1.6 and other parameters drawn from the seed (--vary)" : "")
     << "; " << static_cast<int>(seconds) << " s.\n\n| hidden \\ named |";
  for (EffectKind k : kAllEffectKinds) md << " " << effect_name(k) << " |";
  md << "\n|---|";
  for (std::size_t k = 0; k < kAllEffectKinds.size(); ++k) md << "---|";
  md << "\n";
  for (EffectKind t : kinds) {
    md << "| " << effect_name(t) << " |";
    for (EffectKind n : kAllEffectKinds) {
      const auto it = matrix.find({static_cast<int>(t), static_cast<int>(n)});
      const int cnt = it == matrix.end() ? 0 : it->second;
      md << " " << (t == n && cnt > 0 ? "**" + std::to_string(cnt) + "**" : std::to_string(cnt)) << " |";
    }
    md << "\n";
  }
  const int effect_cases = static_cast<int>(cases.size()) - none_cases;
  md << "\nRight effect named: " << right - none_right << "/" << effect_cases
     << " effect cases; `none` on effect-free data: " << none_right << "/" << none_cases
     << "; RMS error cut by >= 30 % in " << cut_ok << "/" << named_effect
     << " cases where an effect was named.\n";
  std::printf("%s", md.str().c_str());
  if (!o.out_file.empty()) {
    try {
      write_text_atomic(o.out_file, md.str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "omni_fit sweep: %s\n", e.what());
      return 2;
    }
  }
  if (o.json) {
    nlohmann::json j;
    j["cases"] = jcases;
    j["right"] = right;
    j["total"] = cases.size();
    std::printf("%s\n", j.dump().c_str());
  }
  const bool all_good = right == static_cast<int>(cases.size()) && cut_ok == named_effect;
  return (o.require && !all_good) ? 1 : 0;
}

}  // namespace omni_fit
