#include "fit_command.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <string_view>

#include <nlohmann/json.hpp>

#include "alphainv/data/dataset.hpp"
#include "alphainv/diagnose/effect_refinement.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/dataset_split.hpp"
#include "alphainv/identify/fit_model_file.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/identify/fit_report.hpp"
#include "alphainv/identify/validation.hpp"
#include "alphainv/data/model_file.hpp"
#include "common/output_folder.hpp"
#include "plots.hpp"
#include "progress.hpp"
#include "validate_command.hpp"
#include "validation_plots.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

/// The `--json` object of one model's errors (names other tools read).
nlohmann::json errors_json(const ModelErrors& e) {
  return {{"step_median_abs_err", num(e.step_median_abs_err)},
          {"step_p90_abs_err", num(e.step_p90_abs_err)},
          {"phase_p90_deg", num(e.phase_p90_deg)},
          {"magnitude_p90", num(e.magnitude_p90)},
          {"rel_position_error_median", num(e.rel_position_error_median)}};
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
    if (spec == "gravity") {
      // No values: found by --refine-effects' global search (gravity_search.hpp); the placeholder
      // g only switches the term on (its θ0 0 is one of the search's starts).
      if (!opt.refine_effects) {
        throw Error("gravity without values needs --refine-effects (which searches g and θ0); "
                    "or give them, e.g. gravity:gravity_v=0.1,gravity_theta0_rad=0",
                    {}, 0, "--effect gravity");
      }
      effects.gravity_v = 1e-3;
      effects.gravity_theta0_rad = 0.0;
      source += std::string(source.empty() ? "" : ", ") + "`--effect gravity` (searched)";
      continue;
    }
    apply_effect_spec(spec, effects);
    source += std::string(source.empty() ? "" : ", ") + "`--effect " + spec + "`";
  }
}

/// The datasets in `dirs` read and combined (combine_datasets). Throws alphainv::Error.
DatasetWithRuns read_datasets(const std::vector<std::string>& dirs,
                              const std::function<void(std::string_view, std::size_t,
                                                       std::size_t)>& show) {
  std::vector<DatasetWithRuns> parts;
  for (const std::string& dir : dirs) {
    DatasetWithRuns p;
    p.dataset = read_dataset_index(dir);
    for (std::size_t i = 0; i < p.dataset.runs.size(); ++i) {
      if (show) show("loading runs", i, p.dataset.runs.size());
      p.data.push_back(read_run(p.dataset, i));
    }
    parts.push_back(std::move(p));
  }
  return combine_datasets(parts);
}

/// The folders joined for messages: "a", "a + b".
std::string joined(const std::vector<std::string>& dirs) {
  std::string out;
  for (const std::string& d : dirs) out += (out.empty() ? "" : " + ") + d;
  return out;
}

}  // namespace

int run_fit(const FitCommandOptions& opt) {
  Dataset ds;
  std::vector<RunData> data;
  ProgressLine progress(ProgressLine::stderr_wanted(opt.quiet));
  auto show = [&progress](std::string_view stage, std::size_t done, std::size_t total) {
    progress.update(stage, done, total);
  };
  FitPipelineOptions popt;
  std::string effects_source;
  popt.threads = opt.threads;
  popt.n_breakpoints = opt.n_breakpoints;
  popt.disturbance_passes = opt.disturbance_passes;
  DatasetWithRuns held_out;  // --holdout and --validate-on: validated on, not fitted on
  std::string held_out_label;
  try {
    read_known_effects(opt, popt.effects, effects_source);
    popt.validate();
    DatasetWithRuns all = read_datasets(opt.dataset_dirs, show);
    std::vector<DatasetWithRuns> held;
    if (opt.holdout > 0) {
      HoldoutSplit split = holdout_every_kth_run_per_pose(all, opt.holdout);
      all = std::move(split.fit);
      held.push_back(std::move(split.held_out));
      held_out_label = "every K-th run per pose (K = " + std::to_string(opt.holdout) + ") of " +
                       joined(opt.dataset_dirs);
    }
    if (!opt.validate_on.empty()) {
      held.push_back(read_datasets(opt.validate_on, show));
      held_out_label += (held_out_label.empty() ? "" : " + ") + joined(opt.validate_on);
    }
    if (!held.empty()) held_out = combine_datasets(held);
    ds = std::move(all.dataset);
    data = std::move(all.data);
  } catch (const Error& e) {
    progress.clear();
    std::fprintf(stderr, "omni_fit fit: %s\n", e.what());
    return 2;
  }
  // The output goes to a sibling folder, swapped into place at the end (common/output_folder.hpp):
  // checked now, before the work, so `-o` naming a folder of other files costs no fit.
  const fs::path out(opt.out_dir);
  std::optional<common::OutputFolder> folder;
  try {
    folder.emplace(out, std::initializer_list<const char*>{"model.json", "report.md", "plots"});
  } catch (const Error& e) {
    progress.clear();
    std::fprintf(stderr, "omni_fit fit: -o: %s\n", e.what());
    return 2;
  }
  if (progress.enabled()) popt.progress = show;
  EffectRefinement refinement;
  if (opt.refine_effects && active_effects(popt.effects).empty()) {
    progress.clear();
    std::fprintf(stderr, "omni_fit fit: --refine-effects needs known effects (--effects-from or "
                         "--effect)\n");
    return 2;
  }
  const DatasetFit fit = opt.refine_effects
                             ? refine_effects(ds, data, popt, &refinement, opt.refine_evaluations)
                             : fit_dataset(ds, data, popt);
  if (opt.refine_effects) {
    effects_source += "; refined on all runs by --refine-effects (" +
                      std::to_string(refinement.evaluations) + " fits, α-model Σ‖θ_sim − θ‖² " +
                      report_number(refinement.sse_start) + " → " +
                      report_number(refinement.sse_refined) +
                      " over " + std::to_string(refinement.runs_scored) + " runs" +
                      (refinement.message.empty() ? "" : "; " + refinement.message) +
                      (refinement.gravity_search.empty() ? "" : "; " + refinement.gravity_search) +
                      ")";
  }

  ModelFile model;
  try {
    // Every folder fitted on is hashed and named (model.json "dataset"."paths").
    model = fit_model_file(ds, fit, {opt.dataset_dirs.begin(), opt.dataset_dirs.end()});
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit fit: %s\n", e.what());
    return 2;
  }

  // Validation on the held-out runs (validation.hpp), as `omni_fit validate` does.
  std::optional<ValidationResult> validation;
  if (!held_out.dataset.runs.empty() && fit.usable()) {
    ValidationOptions vo;
    vo.threads = opt.threads;
    vo.use_alpha = model.has_alpha_model;
    if (progress.enabled()) show("validating held-out runs", 0, 1);
    validation = validate_model(model, held_out.dataset, held_out.data, vo);
  }
  // A failed fit (exit 3) does not replace a previous output: its report is kept only where
  // there was none.
  const bool keep_previous = !fit.usable() && fs::exists(out / "model.json");
  try {
    const fs::path tmp = folder->path();
    write_model_file(tmp / "model.json", model);
    PlotOptions plot_opt;
    plot_opt.out_dir = tmp;
    if (progress.enabled()) plot_opt.progress = show;
    std::string plot_warning;
    const std::string figures =
        opt.no_plots ? plots_skipped_markdown("--no-plots was given")
                     : draw_report_figures(ds, data, fit, plot_opt, plot_warning);
    progress.clear();
    if (!plot_warning.empty() && !opt.quiet) {
      std::fprintf(stderr, "omni_fit fit: %s\n", plot_warning.c_str());
    }
    FitReportInfo report;
    report.dataset_hash = model.dataset_hash;
    report.dataset_dirs = opt.dataset_dirs;
    report.effects_source = effects_source;
    report.appendix_markdown = figures;
    if (validation) {
      report.appendix_markdown += "\n" + validation_markdown((out / "model.json").string(),
                                                             held_out_label, *validation, "##");
      if (opt.no_plots) {
        report.appendix_markdown +=
            "\n### Validation figures\n\nPlots were skipped: --no-plots was given.\n";
      } else {
        ValidationPlotOptions po;
        po.plot = plot_opt;
        po.plot.progress = nullptr;  // the progress line is cleared by now
        po.prefix = "heldout";
        po.max_runs = opt.plot_runs;
        po.threads = opt.threads;
        std::string warning;
        report.appendix_markdown += draw_validation_figures(held_out.dataset, held_out.data,
                                                            *validation, po, "###", warning);
        if (!warning.empty() && !opt.quiet) std::fprintf(stderr, "omni_fit fit: %s\n", warning.c_str());
      }
    }
    write_text_atomic(tmp / "report.md", fit_report_markdown(ds, fit, report));
    if (!keep_previous) folder->commit();
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
    const KnownDisturbanceCorrection& dc = fit.disturbance_correction;
    j["disturbance_correction"] = {{"runs_with_disturbance", dc.runs_with_disturbance},
                                   {"runs_corrected", dc.runs_corrected},
                                   {"passes", dc.passes},
                                   {"last_point_change", num(dc.last_point_change)},
                                   {"chosen_pass", dc.chosen_pass},
                                   {"first_pass_rms", num(dc.first_pass_rms_rad)},
                                   {"chosen_rms", num(dc.chosen_rms_rad)}};
    j["model"] = (out / "model.json").string();
    if (validation) {
      j["validation"] = validation_json((out / "model.json").string(), held_out_label, *validation);
    }
    std::printf("%s\n", j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  } else if (!opt.quiet) {
    std::printf("omni_fit fit: %zu runs, %zu poses; model %s, report %s\n", ds.runs.size(),
                fit.poses.size(), (out / "model.json").c_str(), (out / "report.md").c_str());
    std::printf("  linear:  step median %s, phase p90 %s deg\n",
                report_number(fit.linear_errors.step_median_abs_err).c_str(),
                report_number(fit.linear_errors.phase_p90_deg).c_str());
    std::printf("  alpha:   step median %s, phase p90 %s deg; step error ratio %s\n",
                report_number(fit.alpha_errors.step_median_abs_err).c_str(),
                report_number(fit.alpha_errors.phase_p90_deg).c_str(),
                report_number(ratio).c_str());
    for (const auto& n : fit.notes) std::printf("  note: %s\n", n.c_str());
    if (validation) std::printf("  held out (%s): %s\n", held_out_label.c_str(),
                                validation->brief_report().c_str());
  }
  if (!fit.usable() && !opt.quiet) {
    std::fprintf(stderr, "omni_fit fit: no model could be identified from %s (%s)\n",
                 joined(opt.dataset_dirs).c_str(),
                 keep_previous ? ("the previous output in " + out.string() +
                                  " is kept; give a new -o folder for this fit's report")
                                     .c_str()
                               : "see report.md");
  }
  return fit.usable() ? 0 : 3;
}

}  // namespace omni_fit
