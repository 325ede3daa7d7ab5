#include "validate_command.hpp"

#include <cstdio>
#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/validation.hpp"
#include "apps/common/exit_code.hpp"
#include "apps/common/report_numbers.hpp"
#include "common/atomic_file.hpp"
#include "common/output_folder.hpp"
#include "validation_plots.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;

nlohmann::json figures_json(const FitFigures& f) {
  return {{"rms", apps::json_number(f.rms)},
          {"max_abs", apps::json_number(f.max_abs)},
          {"fit_percent", apps::json_number(f.fit_percent)},
          {"relative_error", apps::json_number(f.relative_error)}};
}

}  // namespace

nlohmann::json validation_json(const std::string& model, const std::string& dataset,
                               const ValidationResult& r) {
  nlohmann::json runs = nlohmann::json::array();
  for (const ValidatedRun& v : r.runs) {
    nlohmann::json j = figures_json(v.position);
    j["file"] = v.file;
    j["validated"] = v.ok;
    if (!v.ok) j["message"] = v.message;
    j["white"] = v.residual.valid ? nlohmann::json(v.residual.white) : nlohmann::json();
    j["input_correlated"] =
        v.residual.valid ? nlohmann::json(v.residual.input_correlated) : nlohmann::json();
    j["verdict"] = v.residual.verdict();
    j["command"] = figures_json(v.command);
    runs.push_back(j);
  }
  nlohmann::json out = figures_json(r.position);
  out["model"] = model;
  out["dataset"] = dataset;
  out["runs"] = runs;
  out["samples"] = r.position.n;
  out["command"] = figures_json(r.command);
  out["runs_white"] = r.runs_white;
  out["runs_input_correlated"] = r.runs_input_correlated;
  out["runs_tested"] = r.runs_tested;
  return out;
}

std::string validation_markdown(const std::string& model, const std::string& dataset,
                                const ValidationResult& r, const std::string& heading) {
  std::string md = heading + " Validation of `" + model + "` on `" + dataset + "`\n\n" +
                   r.brief_report() + "\n\n";
  if (!r.model_note.empty()) md += "Model: " + r.model_note + ".\n\n";
  md += "Pooled over all samples: θ RMS " + apps::table_cell(r.position.rms) + ", max " +
        apps::table_cell(r.position.max_abs) + ", NRMSE fit " +
        apps::table_cell(r.position.fit_percent, "%.1f") + " %, relative error " +
        apps::table_cell(r.position.relative_error) + "; command v: fit " +
        apps::table_cell(r.command.fit_percent, "%.1f") + " %.\n\n";
  md += "| run | RMS | max | fit % | relative | residual |\n|---|---|---|---|---|---|\n";
  for (const ValidatedRun& v : r.runs) {
    if (!v.ok) {
      md += "| " + v.file + " | – | – | – | – | not validated: " + v.message + " |\n";
      continue;
    }
    md += "| " + v.file + " | " + apps::table_cell(v.position.rms) + " | " +
          apps::table_cell(v.position.max_abs) + " | " +
          apps::table_cell(v.position.fit_percent, "%.1f") + " | " +
          apps::table_cell(v.position.relative_error) + " | " + v.residual.verdict() + " |\n";
  }
  md += "\nFit % is MATLAB compare's NRMSE fit 100·(1 − ‖y − ŷ‖/‖y − ȳ‖); relative error "
        "‖y − ŷ‖/‖y‖ (the EMPS benchmark's). Residual tests as MATLAB resid: autocorrelation of "
        "θ − θ_sim and its cross-correlation with the reference, 99 % bands, portmanteau verdicts.\n";
  return md;
}

CLI::App* add_validate_subcommand(CLI::App& app, ValidateCommandOptions& o) {
  auto* c = app.add_subcommand(
      "validate", "how well a model.json predicts recorded runs (compare and resid, per run and pooled)");
  c->add_option("model", o.model_path, "model.json (from omni_fit fit or diagnose)")->required();
  c->add_option("dataset", o.dataset_dir, "dataset folder of the runs to validate on")->required();
  c->add_option("-o,--out", o.out_dir, "write report.md and validation.json into this folder");
  c->add_flag("--json", o.json, "print the figures as one JSON object");
  c->add_option("--initial-samples", o.initial_samples,
                "fit the initial state on the first N samples of each run (then left out of the "
                "figures); default: the measured state");
  c->add_flag("--linear", o.linear, "validate the global linear model instead of the alpha-model");
  c->add_flag("--ignore-known-inputs", o.ignore_known_inputs,
              "do not apply the runs' disturbance_v and torque_enable columns (to measure what "
              "they explain); default: applied to the plant");
  c->add_option("--max-lag", o.max_lag, "lags of the residual tests")->capture_default_str()
      ->check(CLI::Range(1, 1000));
  c->add_option("--threads", o.threads, "threads (default: all cores)");
  c->add_flag("--no-plots", o.no_plots, "with -o: no figures (plots/ is not written)");
  c->add_option("--plot-runs", o.plot_runs,
                "with -o: runs shown in the compare and resid figures (all when the dataset has "
                "at most N validated runs, else the N with the lowest fit %)")
      ->capture_default_str()->check(CLI::Range(0, 100000));
  c->add_flag("-q,--quiet", o.quiet, "no report on stdout");
  c->footer("Examples:\n  omni_fit fit data/omni_yaw_sim -o out/fit\n"
            "  omni_fit validate out/fit/model.json other_runs/ --json\n"
            "  omni_fit validate out/fit/model.json other_runs/ -o out/val   # report.md, figures\n"
            "Exit codes: 0 ok, 1 usage, 2 bad model or dataset, 3 no run could be validated.");
  return c;
}

int run_validate(const ValidateCommandOptions& o) {
  ModelFile model;
  Dataset ds;
  std::vector<RunData> data;
  try {
    model = read_model_file(o.model_path);
    ds = read_dataset_index(o.dataset_dir);
    for (std::size_t i = 0; i < ds.runs.size(); ++i) data.push_back(read_run(ds, i));
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit validate: %s\n", e.what());
    return apps::exit_status(apps::ExitCode::kBadInput);
  }
  // The output goes to a sibling folder swapped into place at the end (common/output_folder.hpp).
  std::optional<common::OutputFolder> folder;
  if (!o.out_dir.empty()) {
    try {
      folder.emplace(o.out_dir, std::initializer_list<const char*>{"report.md", "validation.json", "plots"});
    } catch (const Error& e) {
      std::fprintf(stderr, "omni_fit validate: -o: %s\n", e.what());
      return apps::exit_status(apps::ExitCode::kBadInput);
    }
  }
  ValidationOptions vo;
  vo.initial_samples = o.initial_samples;
  vo.use_alpha = !o.linear;
  vo.use_known_inputs = !o.ignore_known_inputs;
  vo.residual.max_lag = o.max_lag;
  vo.threads = o.threads;
  const ValidationResult r = validate_model(model, ds, data, vo);
  const nlohmann::json j = validation_json(o.model_path, o.dataset_dir, r);
  if (folder) {
    try {
      std::string md = validation_markdown(o.model_path, o.dataset_dir, r, "#");
      if (o.no_plots) {
        md += "\n## Validation figures\n\nPlots were skipped: --no-plots was given.\n";
      } else {
        ValidationPlotOptions po;
        po.plot.out_dir = folder->path();
        po.max_runs = o.plot_runs;
        po.threads = o.threads;
        std::string warning;
        md += draw_validation_figures(ds, data, r, po, "##", warning);
        if (!warning.empty() && !o.quiet) std::fprintf(stderr, "omni_fit validate: %s\n", warning.c_str());
      }
      common::write_file_atomically(folder->path() / "report.md", md);
      common::write_file_atomically(folder->path() / "validation.json", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
      folder->commit();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "omni_fit validate: %s\n", e.what());
      return apps::exit_status(apps::ExitCode::kBadInput);
    }
  }
  if (o.json) {
    std::printf("%s\n", j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  } else if (!o.quiet) {
    std::printf("%s", r.full_report().c_str());
  }
  if (std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::fprintf(stderr, "omni_fit validate: could not write to stdout\n");
    return apps::exit_status(apps::ExitCode::kBadInput);
  }
  if (!r.ok) {
    std::fprintf(stderr, "omni_fit validate: %s\n", r.message.c_str());
    return apps::exit_status(apps::ExitCode::kFailed);
  }
  return apps::exit_status(apps::ExitCode::kOk);
}

}  // namespace omni_fit
