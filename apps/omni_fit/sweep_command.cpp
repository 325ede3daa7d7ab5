#include "sweep_command.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <random>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/diagnose/discovered_term.hpp"
#include "alphainv/error.hpp"
#include "alphainv/simulate/experiment_plan.hpp"
#include "apps/common/exit_code.hpp"
#include "common/parallel_for.hpp"
#include "plots.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;

/// One generated case.
struct SweepCase {
  EffectKind effect = EffectKind::kNone;
  double magnitude = 0.0;  ///< the effect's first parameter (see apply)
  double noise_std_rad = 5e-5;
  std::uint64_t seed = 1;
  /// --vary: the magnitude's factor, and the effect's other parameters drawn from the seed
  /// (EffectParameter::sweep_vary_lo, sweep_vary_span); otherwise factor 1 and their sweep_fixed values.
  double factor = 1.0;
  std::vector<double> others;  ///< the effect's parameters after the first, in table order
  bool varied = false;
};

/// The effect's other parameters with a sweep value (those with a --vary range or a fixed value).
std::vector<const EffectParameter*> swept_others(EffectKind kind) {
  std::vector<const EffectParameter*> out;
  const EffectSpec& spec = effect_spec(kind);
  for (std::size_t j = 1; j < spec.parameter_count; ++j) {
    const EffectParameter& p = spec.parameters[j];
    if (!p.modelling_choice) out.push_back(&p);
  }
  return out;
}

/// The fixed values of a case's other parameters.
void set_fixed(SweepCase& c) {
  c.others.clear();
  for (const EffectParameter* p : swept_others(c.effect)) c.others.push_back(p->sweep_fixed);
}

/// The --vary draws of a case (deterministic in the seed and the effect): the factor, then each
/// other parameter with a range, in table order.
void draw_variation(SweepCase& c) {
  std::mt19937_64 rng(c.seed * 1315423911u + static_cast<std::uint64_t>(c.effect) * 2654435761u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  c.factor = std::exp(std::log(0.6) + u(rng) * (std::log(1.6) - std::log(0.6)));  // 0.6 … 1.6
  c.others.clear();
  for (const EffectParameter* p : swept_others(c.effect)) {
    c.others.push_back(p->sweep_vary_span > 0.0 ? p->sweep_vary_lo + u(rng) * p->sweep_vary_span
                                                : p->sweep_fixed);
  }
  c.varied = true;
}

/// The hidden effect's first parameter: the magnitude times the factor (a larger factor is a
/// stronger effect: for a saturation, a lower limit).
double hidden_magnitude(const SweepCase& c) {
  return effect_spec(c.effect).stronger_when_smaller ? c.magnitude / c.factor : c.magnitude * c.factor;
}

/// Sets the hidden effect on the plant. Magnitudes are in the plant's units (V, s, rad).
void apply(const SweepCase& c, Effects& e) {
  if (c.effect == EffectKind::kNone) return;
  const EffectSpec& spec = effect_spec(c.effect);
  e.*(spec.parameters[0].member) = hidden_magnitude(c);
  const std::vector<const EffectParameter*> others = swept_others(c.effect);
  for (std::size_t j = 0; j < others.size() && j < c.others.size(); ++j)
    e.*(others[j]->member) = c.others[j] * (others[j]->sweep_times_first ? hidden_magnitude(c) : 1.0);
}

/// Two magnitudes per effect: clearly visible, and about half of that (EffectSpec).
std::vector<double> magnitudes(EffectKind k) {
  if (k == EffectKind::kNone) return {0.0};
  const auto& m = effect_spec(k).sweep_magnitudes;
  return {m[0], m[1]};
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
              "exit 3 unless every case names its effect (cutting the RMS error by >= 30 %) and "
              "every effect-free case says none");
  c->add_flag("--json", o.json, "print the cases as one JSON object (alone on standard output)");
  c->add_flag("--no-discover", o.no_discover,
              "no discovered term after the named effects (as omni_fit diagnose --no-discover): the "
              "verdict judges the named effects alone");
  c->add_option("--threads", o.threads, "cases diagnosed side by side, one thread each (default: all cores)");
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
    return apps::exit_status(apps::ExitCode::kUsage);
  }
  if (kinds.empty()) {
    for (EffectKind k : kAllEffectKinds) {
      if (effect_spec(k).candidate) kinds.push_back(k);  // (not the discovered term)
    }
  }
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
          for (int r = 0; r < repeat; ++r) {
            SweepCase c;
            c.effect = k;
            c.magnitude = m;
            c.noise_std_rad = noise;
            c.seed = seed + 1000u * static_cast<std::uint64_t>(r);
            cases.push_back(c);
          }
  }
  for (SweepCase& c : cases) {
    if (o.vary) draw_variation(c);
    else set_fixed(c);
  }
  std::map<std::pair<int, int>, int> matrix;  // (true, named) → count
  int right = 0, named_effect = 0, cut_ok = 0, none_cases = 0, none_right = 0;
  int none_explained = 0, right_explained = 0;  // ... and the verdict: explained to the noise floor
  nlohmann::json jcases = nlohmann::json::array();
  const auto t0 = std::chrono::steady_clock::now();
  // The cases run side by side, one thread each (diagnose's own parallelism is over a case's
  // simulations, which a 10-run case does not keep two cores busy with); the results are read
  // in case order below, so the output does not depend on the threads.
  const unsigned threads = common::thread_count(o.threads, cases.size());
  std::vector<DiagnoseResult> results(cases.size());
  std::mutex progress;
  common::parallel_for(cases.size(), threads, [&](std::size_t ci) {
    const SweepCase& c = cases[ci];
    ExperimentPlanOptions plan = paper_plan_options(c.seed);
    plan.plant.effects.coulomb_v = 0.0;  // only the hidden effect
    apply(c, plan.plant.effects);
    // A torque of time (external_disturbance) is hidden as omni_gen's pulses with their column
    // left out: the magnitude is the pulses' amplitude.
    const bool of_time = effect_spec(c.effect).role == EffectRole::kTimeSeries;
    if (of_time) {
      plan.plant.effects.disturbance_rms_v = 0.0;
      plan.disturbance_pulses.amplitude_v = hidden_magnitude(c);
    }
    plan.plant.measurement.noise_std_rad = c.noise_std_rad;
    const auto poses = paper_sine_poses();
    const PoseSetPoint pose = poses[static_cast<std::size_t>(c.seed % poses.size())];
    plan.sine_poses = {pose};
    plan.square_poses = {pose};
    GeneratedDataset gen = generate_dataset(make_experiment_plan(plan));
    if (of_time) {
      for (RunData& run : gen.runs) run.extra_columns.erase("disturbance_v");
    }
    DiagnoseOptions dopt;
    dopt.threads = 1;
    // The matrix counts the first name: one round (the rounds after it are the confusion
    // script's, scripts/diagnose_confusion.py, over omni_fit diagnose's default of 3).
    dopt.max_effects = 1;
    dopt.discover = !o.no_discover;
    results[ci] = diagnose_dataset(gen.index, gen.runs, dopt);
    const DiagnoseResult& r = results[ci];
    const EffectKind named = r.ok && !r.effects_named.empty() ? r.effects_named.front() : EffectKind::kNone;
    const std::lock_guard<std::mutex> lock(progress);
    std::fprintf(stderr, "[%zu/%zu] %-16s %-8.3g noise %.0e seed %llu -> %-16s RMS %.3g -> %.3g %.1f s\n",
                 ci + 1, cases.size(), effect_name(c.effect), hidden_magnitude(c), c.noise_std_rad,
                 static_cast<unsigned long long>(c.seed), effect_name(named), r.error_before,
                 r.error_after, r.seconds);
  });
  const auto poses = paper_sine_poses();
  for (std::size_t ci = 0; ci < cases.size(); ++ci) {
    const SweepCase& c = cases[ci];
    const DiagnoseResult& r = results[ci];
    const EffectKind named = r.ok && !r.effects_named.empty() ? r.effects_named.front() : EffectKind::kNone;
    const double cut = r.error_before > 0 ? 1.0 - r.error_after / r.error_before : 0.0;
    ++matrix[{static_cast<int>(c.effect), static_cast<int>(named)}];
    const bool ok_name = named == c.effect;
    right += ok_name;
    const bool explained = r.ok && r.verdict.verdict == ResidualVerdict::kExplained;
    if (c.effect == EffectKind::kNone) {
      ++none_cases;
      none_right += ok_name;
      none_explained += ok_name && explained;
    } else {
      right_explained += ok_name && explained;
    }
    if (named != EffectKind::kNone) {
      ++named_effect;
      cut_ok += cut >= 0.30;
    }
    const double magnitude = hidden_magnitude(c);
    std::fprintf(stderr, "%-16s %-8.3g noise %.0e seed %llu -> %-16s RMS %.3g -> %.3g (%.0f %%) %.1f s, %s%s\n",
                 effect_name(c.effect), magnitude, c.noise_std_rad,
                 static_cast<unsigned long long>(c.seed), effect_name(named), r.error_before,
                 r.error_after, 100.0 * cut, r.seconds,
                 explained ? "explained" : "structure remains", ok_name ? "" : "  WRONG");
    Effects hidden;
    apply(c, hidden);
    // The same dataset from the command line (omni_gen), to look at one case closely.
    std::ostringstream gen_cmd;
    gen_cmd.precision(6);
    gen_cmd << "omni_gen paper -o DIR --seed " << c.seed << " --pose " << c.seed % poses.size()
            << (hidden.coulomb_v > 0.0 ? "" : " --no-coulomb") << " --noise-std " << c.noise_std_rad;
    for (EffectKind k : active_effects(hidden)) {
      if (effect_spec(k).role == EffectRole::kTimeSeries) {
        gen_cmd << " --disturbance-pulses " << magnitude << " --unrecorded-disturbance";
      } else {
        gen_cmd << " --effect " << effect_spec_text(hidden, k);
      }
    }
    const auto parts = [](const std::vector<UnexplainedPart>& list) {
      nlohmann::json out = nlohmann::json::array();
      for (const UnexplainedPart& u : list) out.push_back({{"where", u.where}, {"ratio", u.ratio}});
      return out;
    };
    nlohmann::json not_separable = nlohmann::json::array();  // (separability.hpp)
    for (const NotSeparable& n : r.not_separable) not_separable.push_back(effect_name(n.effect));
    nlohmann::json effects_named = nlohmann::json::array();  // (`named` is the first of them)
    for (EffectKind k : r.effects_named) effects_named.push_back(effect_name(k));
    // The discovered term (null: not tried): kept or not, its reading, and the named effect whose
    // place it took (discovered_term.hpp), which is then not among effects_named.
    nlohmann::json discovered = nullptr;
    if (r.discovered) {
      const DiscoveredTermResult& d = *r.discovered;
      discovered = {{"ok", d.ok}, {"kept", d.kept}, {"reading", d.reading},
                    {"error_after", d.error_after},
                    {"took_in", d.took_in == EffectKind::kNone ? nlohmann::json(nullptr)
                                                               : nlohmann::json(effect_name(d.took_in))}};
    }
    jcases.push_back({{"effect", effect_name(c.effect)}, {"magnitude", magnitude},
                      {"hidden", effects_text(hidden)}, {"generate", gen_cmd.str()},
                      {"noise_std_rad", c.noise_std_rad}, {"seed", c.seed},
                      {"named", effect_name(named)}, {"error_before", r.error_before},
                      {"error_after", r.error_after}, {"seconds", r.seconds},
                      {"verdict", verdict_name(r.verdict.verdict)},
                      {"noise_floor", r.noise_floor.rms},
                      {"structure_rms", r.verdict.structure_rms},
                      {"fundamental_median", r.verdict.fundamental_median},
                      {"fundamental_runs_above", r.verdict.fundamental_runs_above},
                      {"unexplained", parts(r.verdict.unexplained)},
                      {"not_judged", parts(r.verdict.not_judged)},  // (verdict.hpp VerdictReport::not_judged)
                      {"not_separable", not_separable}, {"effects_named", effects_named},
                      {"discovered", discovered}});
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
     << " cases where an effect was named.\nVerdict: effect-free named `none` and explained to the "
        "noise floor: "
     << none_explained << "/" << none_cases << "; right effect named and explained: "
     << right_explained << "/" << effect_cases << ".\n";
  // With --json, standard output is the JSON object alone (for jq and scripts); the table goes to
  // -o when asked for.
  if (!o.json) std::printf("%s", md.str().c_str());
  if (!o.out_file.empty()) {
    try {
      write_text_atomic(o.out_file, md.str());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "omni_fit sweep: %s\n", e.what());
      return apps::exit_status(apps::ExitCode::kBadInput);
    }
  }
  if (o.json) {
    nlohmann::json j;
    j["cases"] = jcases;
    j["right"] = right;
    j["total"] = cases.size();
    std::printf("%s\n", j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  }
  const bool all_good = right == static_cast<int>(cases.size()) && cut_ok == named_effect;
  return apps::exit_status(o.require && !all_good ? apps::ExitCode::kFailed : apps::ExitCode::kOk);
}

}  // namespace omni_fit
