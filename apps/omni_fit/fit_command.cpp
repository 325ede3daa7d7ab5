#include "fit_command.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "alphainv/data/dataset.hpp"
#include "alphainv/diagnose/effect_refinement.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/data/model_file.hpp"
#include "plots.hpp"
#include "progress.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

std::string fmt(double x, const char* f = "%.4g") {
  if (!std::isfinite(x)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, f, x);
  return b;
}

/// Table cells of one model's errors: magnitude p90 | phase p90 | step median | step p90.
std::string error_cells(const ModelErrors& e) {
  return fmt(e.magnitude_p90) + " | " + fmt(e.phase_p90_deg) + " | " + fmt(e.step_median_abs_err) +
         " | " + fmt(e.step_p90_abs_err);
}

/// The `--json` object of one model's errors (names other tools read).
nlohmann::json errors_json(const ModelErrors& e) {
  return {{"step_median_abs_err", num(e.step_median_abs_err)},
          {"step_p90_abs_err", num(e.step_p90_abs_err)},
          {"phase_p90_deg", num(e.phase_p90_deg)},
          {"magnitude_p90", num(e.magnitude_p90)},
          {"rel_position_error_median", num(e.rel_position_error_median)}};
}

std::string pose_label(const PoseFit& p) {
  if (!p.gamma1_deg) return "(no pose)";
  return fmt(*p.gamma1_deg, "%.2f") + "° / " + fmt(*p.gamma2_deg, "%.2f") + "°";
}

/// `effects_source`: where the known effects came from (for the report), empty without them.
std::string make_report(const Dataset& ds, const DatasetFit& fit, const ModelFile& model,
                        const std::string& effects_source) {
  std::ostringstream r;
  r << "# omni_fit report\n\n";
  r << "Dataset: `" << ds.dir.string() << "` (" << ds.runs.size() << " runs, " << fit.poses.size()
    << " poses, position unit " << ds.position_unit << ", command unit " << ds.command_unit
    << "), hash " << model.dataset_hash << ".\n\n";
  if (!active_effects(fit.effects).empty()) {
    r << "**Fitted with known effects** (" << effects_source << "): " << effects_text(fit.effects)
      << ". The local points of the sine runs were corrected for them (C_data, β_data against the "
         "plant input through the effects), the validation simulations include them, and "
         "model.json carries them.\n\n";
  }
  if (!fit.notes.empty()) {
    r << "## What the data could and could not support\n\n";
    for (const auto& n : fit.notes) r << "- " << n << "\n";
    r << "\n";
  }
  r << "## Local linear points (eqs. 19, 20, 36)\n\n";
  if (fit.loop_period_s > 0.0) {
    r << "Digital loop: C_data and β_data are the exact inversion of the sampled-data P loop "
         "(command held for T = "
      << fmt(1e3 * fit.loop_period_s)
      << " ms), not eqs. (19)-(20) as printed, which read C low by about ω²T/2 (see notes).\n\n";
  }
  r << "| run | pose | f [Hz] | gain | phase [°] | C_data | β_data | α_data | physical "
       "|\n|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& sp : fit.sine_points) {
    r << "| " << ds.runs[sp.run].file << " | " << pose_label(fit.poses[sp.pose]) << " | "
      << fmt(sp.point.freq_hz) << " | " << fmt(sp.gain) << " | " << fmt(sp.phase_deg, "%.2f") << " | "
      << fmt(sp.point.c_data) << " | " << fmt(sp.point.beta_data) << " | " << fmt(sp.point.alpha_data)
      << " | " << (sp.point.physical ? "yes" : "**no**") << " |\n";
  }
  r << "\n## Global linear model per pose (eq. 22)\n\n| pose | band [Hz] | C_linear | β_linear | "
       "β̃_linear | I (model) |\n|---|---|---|---|---|---|\n";
  for (const auto& p : fit.poses) {
    if (!p.linear.valid) continue;
    const bool from_sine = p.linear_source == "sine (22)";
    r << "| " << pose_label(p) << " | "
      << (from_sine ? fmt(p.band_lo_hz, "%.2f") + "–" + fmt(p.band_hi_hz, "%.2f")
                    : std::string("– (") + p.linear_source + ")")
      << " | " << fmt(p.linear.c_linear) << " | " << fmt(p.linear.beta_linear) << " | "
      << fmt(p.linear.beta_tilde_linear) << " | " << fmt(p.inertia, "%.6g") << " |\n";
  }
  r << "\nBand: [f_res/1.3, 1.3 f_res] around the frequency of largest measured gain (the paper uses "
       "3–4.5 Hz around its 3.4 Hz resonance), all physical points when fewer than two fall in it.\n";
  if (fit.has_inertia_model) {
    const auto& s = fit.inertia;
    r << "\n## Inertia model (eqs. 6, 27–29, Ceres)\n\n| parameter | value | standard error | poorly "
         "determined |\n|---|---|---|---|\n";
    for (int k = 0; k < kInertiaFitParameterCount; ++k) {
      r << "| " << inertia_fit_parameter_name(k) << " | " << fmt(s.parameters[static_cast<std::size_t>(k)], "%.5g")
        << " | " << fmt(s.standard_errors[static_cast<std::size_t>(k)], "%.3g") << " | "
        << (s.poorly_determined[static_cast<std::size_t>(k)] ? "yes" : "no") << " |\n";
    }
    r << "\nRMS relative error of the model: C_linear " << fmt(100 * s.rms_relative_c, "%.2f")
      << " %, β̃_linear " << fmt(100 * s.rms_relative_beta_tilde, "%.2f") << " %.";
    if (!s.warning.empty()) r << " Warning: " << s.warning;
    r << "\n";
  }
  if (fit.alpha.ok) {
    const AlphaModel& a = fit.alpha.model;
    if (fit.alpha_source == "sine (2.3.5)") {
      r << "\n## α-invariant model (eqs. 38–42; breakpoints by exhaustive grid search over "
        << fit.alpha.candidates_tried << " sets"
        << (fit.alpha.refined ? ", refined by NLopt Nelder-Mead" : "") << ")\n\n"
        << "The data cover α = " << fmt(fit.alpha.alpha_data_min) << " … "
        << fmt(fit.alpha.alpha_data_max)
        << ". A breakpoint is pinned when data lie on both sides of it; a coefficient is "
           "identifiable when it is measured inside the data (not extrapolated) with relative SE "
           "≤ 10 %. Trust C(α, I) and β̃(α, I) inside the α range.\n\n";
    } else {
      r << "\n## α-invariant model (eqs. 38–42; time domain: output error, breakpoints at "
           "quantiles of the commands' α)\n\n";
    }
    r << "| n | α_n | pinned | C_n1 | SE | identifiable |\n|---|---|---|---|---|---|\n";
    for (std::size_t k = 0; k < a.n_breakpoints; ++k) {
      r << "| " << k << " | " << fmt(a.alpha[k]) << " | "
        << (k == 0                                 ? "convention"
            : fit.alpha.breakpoint_identifiable[k] ? "yes"
                                                   : "**no**")
        << " | " << fmt(a.c_n1[k]) << " | " << fmt(fit.alpha.c_n1_se[k], "%.3g") << " | "
        << (fit.alpha.c_n1_identifiable[k] ? "yes" : "**no**") << " |\n";
    }
    r << "\nβ̃_n1 = " << fmt(a.beta_n1[0]) << " ± " << fmt(fit.alpha.beta_n1_se[0], "%.2g")
      << (fit.alpha.beta_n1_identifiable[0] ? "" : " (**not identifiable**)")
      << " at α = " << fmt(a.beta_alpha[0]) << ", " << fmt(a.beta_n1[1]) << " ± "
      << fmt(fit.alpha.beta_n1_se[1], "%.2g")
      << (fit.alpha.beta_n1_identifiable[1] ? "" : " (**not identifiable**)")
      << " at α = " << fmt(a.beta_alpha[1]) << ". RMS relative error on the "
      << "data: C " << fmt(100 * fit.alpha.c_rms_relative, "%.2f") << " %, β̃ "
      << fmt(100 * fit.alpha.beta_rms_relative, "%.2f") << " %.\n";
  }
  r << "\n## Validation: every run simulated under its own controller\n\n"
       "Table 8 style (90th percentile over each pose's sweep) and Table 11 style (|θ_sim − θ| of "
       "square/step runs, median and 90th percentile), per pose:\n\n"
       "| pose | lin mag p90 | lin phase p90 [°] | lin step median | lin step p90 | α mag p90 | α "
       "phase p90 [°] | α step median | α step p90 |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& p : fit.poses) {
    r << "| " << pose_label(p) << " | " << error_cells(p.linear_errors) << " | "
      << error_cells(p.alpha_errors) << " |\n";
  }
  r << "| **median** | " << error_cells(fit.linear_errors) << " | " << error_cells(fit.alpha_errors)
    << " |\n";
  r << "\nRelative position error ‖θ_sim − θ‖/‖θ‖ per run:\n\n| run | linear | α-model |\n|---|---|---|\n";
  for (const auto& v : fit.validation) {
    if (!v.simulated) continue;
    r << "| " << ds.runs[v.run].file << " | " << fmt(100 * v.linear.rel_position_error, "%.4f")
      << " % | " << fmt(100 * v.alpha.rel_position_error, "%.4f") << " % |\n";
  }
  return r.str();
}

/// Reads the known effects of --effects-from and --effect into `effects` and says where they came
/// from in `source`. Throws alphainv::Error naming the file or the option.
void read_known_effects(const FitCommandOptions& opt, Effects& effects, std::string& source) {
  if (!opt.effects_from.empty()) {
    ModelFile from;
    try {
      from = read_model_file(opt.effects_from);
    } catch (const Error& e) {  // its message names the file (and the key)
      throw Error(e.what(), {}, 0, "--effects-from");
    }
    if (active_effects(from.effects).empty()) {
      throw Error(opt.effects_from + " has no effects (its \"effects\" list is empty or absent); "
                  "`omni_fit diagnose` writes a model.json that has",
                  {}, 0, "--effects-from");
    }
    effects = from.effects;
    source = "from `" + opt.effects_from + "`";
  }
  for (const std::string& spec : opt.effect_specs) {
    apply_effect_option(spec, effects);
    source += std::string(source.empty() ? "" : ", ") + "`--effect " + spec + "`";
  }
}

}  // namespace

void apply_effect_option(const std::string& spec, Effects& effects) {
  const std::string option = "--effect " + spec;
  const std::size_t colon = spec.find(':');
  if (colon == std::string::npos) {
    throw Error("expected NAME:PARAM=VALUE[,PARAM=VALUE], e.g. coulomb_friction:coulomb_v=0.004", {},
                0, option);
  }
  const EffectKind kind = effect_kind_from_name(spec.substr(0, colon), option);
  const std::vector<EffectParameter> known = effect_parameters(kind, true);
  std::string names;
  for (const EffectParameter& p : known) names += std::string(names.empty() ? "" : ", ") + p.name;
  if (kind == EffectKind::kNone) throw Error("\"none\" is not an effect to fit with", {}, 0, option);
  Effects one;  // this effect's values on defaults: validate_effects can only object to them
  std::size_t start = colon + 1;
  bool any = false;
  while (start <= spec.size()) {
    const std::size_t end = std::min(spec.find(',', start), spec.size());
    const std::string item = spec.substr(start, end - start);
    const std::size_t eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const EffectParameter* param = nullptr;
    for (const EffectParameter& p : known) {
      if (key == p.name) param = &p;
    }
    if (eq == std::string::npos || param == nullptr) {
      throw Error("expected PARAM=VALUE with PARAM one of " + names + ", found \"" + item + "\"", {},
                  0, option);
    }
    const std::string text = item.substr(eq + 1);
    char* rest = nullptr;
    const double x = std::strtod(text.c_str(), &rest);
    if (text.empty() || rest == nullptr || *rest != '\0') {
      throw Error("expected a number for " + key + ", found \"" + text + "\"", {}, 0, option);
    }
    one.*(param->member) = x;
    any = true;
    start = end + 1;
  }
  if (!any) throw Error("no parameter given", {}, 0, option);
  validate_effects(one, "--effect " + spec.substr(0, colon) + ":");
  if (!effect_active(one, kind)) {
    throw Error("these values leave " + std::string(effect_name(kind)) + " off", {}, 0, option);
  }
  for (const EffectParameter& p : known) effects.*(p.member) = one.*(p.member);
}

ModelFile make_model_file(const Dataset& ds, const DatasetFit& fit) {
  ModelFile model;
  model.tool_version = "alphainv 0.1.0";
  std::vector<std::string> files;
  for (const auto& r : ds.runs) files.push_back(r.file);
  model.dataset_hash = hash_dataset(ds.dir, files);
  model.dataset_path = fs::absolute(ds.dir).string();
  model.position_unit = ds.position_unit;
  model.command_unit = ds.command_unit;
  model.controller = ds.runs.front().controller;
  model.has_inertia_model = fit.has_inertia_model;
  if (fit.has_inertia_model) {
    model.linear = fit.inertia.model;
    for (std::size_t k = 0; k < 6; ++k) model.linear_se[k] = fit.inertia.standard_errors[k];
  }
  for (const auto& p : fit.poses) {
    if (!p.linear.valid) continue;
    model.poses.push_back({p.gamma1_deg, p.gamma2_deg, p.linear.c_linear, p.linear.beta_tilde_linear});
  }
  model.has_alpha_model = fit.alpha.ok;
  if (fit.alpha.ok) {
    model.alpha = fit.alpha.model;
    model.c_n1_se = fit.alpha.c_n1_se;
    model.beta_n1_se = fit.alpha.beta_n1_se;
  }
  model.effects = fit.effects;  // the known effects the model was fitted with
  model.loop_period_s = fit.simulation.loop_period_s;  // the simulation the model was identified with
  model.notes = fit.notes;
  return model;
}

int run_fit(const FitCommandOptions& opt) {
  Dataset ds;
  std::vector<RunData> data;
  ProgressLine progress(ProgressLine::stderr_wanted(opt.quiet));
  auto show = [&progress](std::string_view stage, std::size_t done, std::size_t total) {
    progress.update(stage, done, total);
  };
  FitPipelineOptions popt;
  std::string effects_source;
  try {
    read_known_effects(opt, popt.effects, effects_source);
    ds = read_dataset_index(opt.dataset_dir);
    for (std::size_t i = 0; i < ds.runs.size(); ++i) {
      show("loading runs", i, ds.runs.size());
      data.push_back(read_run(ds, i));
    }
  } catch (const Error& e) {
    progress.clear();
    std::fprintf(stderr, "omni_fit fit: %s\n", e.what());
    return 2;
  }
  if (progress.enabled()) popt.progress = show;
  popt.threads = opt.threads;
  popt.n_breakpoints = opt.n_breakpoints;
  EffectRefinement refinement;
  if (opt.refine_effects && active_effects(popt.effects).empty()) {
    progress.clear();
    std::fprintf(stderr, "omni_fit fit: --refine-effects needs known effects (--effects-from or "
                         "--effect)\n");
    return 2;
  }
  const DatasetFit fit = opt.refine_effects ? refine_effects(ds, data, popt, &refinement)
                                            : fit_dataset(ds, data, popt);
  if (opt.refine_effects) {
    effects_source += "; refined on all runs by --refine-effects (" +
                      std::to_string(refinement.evaluations) + " fits, α-model Σ‖θ_sim − θ‖² " +
                      fmt(refinement.sse_start) + " → " + fmt(refinement.sse_refined) +
                      " over " + std::to_string(refinement.runs_scored) + " runs" +
                      (refinement.message.empty() ? "" : "; " + refinement.message) + ")";
  }

  ModelFile model;
  try {
    model = make_model_file(ds, fit);
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit fit: %s\n", e.what());
    return 2;
  }

  const fs::path out(opt.out_dir);
  try {
    fs::create_directories(out);
    write_model_file(out / "model.json", model);
    PlotOptions plot_opt;
    plot_opt.out_dir = out;
    if (progress.enabled()) plot_opt.progress = show;
    std::string plot_warning;
    const std::string figures =
        opt.no_plots ? plots_skipped_markdown("--no-plots was given")
                     : draw_report_figures(ds, data, fit, plot_opt, plot_warning);
    progress.clear();
    if (!plot_warning.empty() && !opt.quiet) {
      std::fprintf(stderr, "omni_fit fit: %s\n", plot_warning.c_str());
    }
    write_text_atomic(out / "report.md", make_report(ds, fit, model, effects_source) + figures);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "omni_fit fit: writing %s: %s\n", out.string().c_str(), e.what());
    return 2;
  }
  const double ratio = fit.alpha_errors.step_median_abs_err > 0.0
                           ? fit.linear_errors.step_median_abs_err / fit.alpha_errors.step_median_abs_err
                           : std::nan("");
  if (opt.json) {
    nlohmann::json j;
    j["runs"] = ds.runs.size();
    j["poses"] = fit.poses.size();
    j["linear"] = errors_json(fit.linear_errors);
    j["alpha"] = errors_json(fit.alpha_errors);
    j["step_error_ratio"] = num(ratio);
    j["model"] = (out / "model.json").string();
    std::printf("%s\n", j.dump().c_str());
  } else if (!opt.quiet) {
    std::printf("omni_fit fit: %zu runs, %zu poses; model %s, report %s\n", ds.runs.size(),
                fit.poses.size(), (out / "model.json").c_str(), (out / "report.md").c_str());
    std::printf("  linear:  step median %s, phase p90 %s deg\n",
                fmt(fit.linear_errors.step_median_abs_err).c_str(),
                fmt(fit.linear_errors.phase_p90_deg).c_str());
    std::printf("  alpha:   step median %s, phase p90 %s deg; step error ratio %s\n",
                fmt(fit.alpha_errors.step_median_abs_err).c_str(),
                fmt(fit.alpha_errors.phase_p90_deg).c_str(),
                fmt(ratio).c_str());
    for (const auto& n : fit.notes) std::printf("  note: %s\n", n.c_str());
  }
  bool any_model = fit.alpha.ok;
  for (const auto& p : fit.poses) any_model = any_model || p.linear.valid;
  if (!any_model && !opt.quiet) {
    std::fprintf(stderr, "omni_fit fit: no model could be identified from %s (see report.md)\n",
                 opt.dataset_dir.c_str());
  }
  return any_model ? 0 : 3;
}

}  // namespace omni_fit
