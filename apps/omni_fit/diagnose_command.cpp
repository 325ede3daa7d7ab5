#include "diagnose_command.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "alphainv/data/dataset.hpp"
#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/diagnose/diagnose_report.hpp"
#include "alphainv/diagnose/diagnosed_model_file.hpp"
#include "alphainv/diagnose/discovered_term.hpp"
#include "alphainv/diagnose/run_levels.hpp"
#include "alphainv/identify/fit_model_file.hpp"
#include "alphainv/error.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/model_simulation.hpp"
#include "common/output_folder.hpp"
#include "fit_command.hpp"
#include "plots.hpp"

namespace omni_fit {

namespace {

using namespace alphainv;
namespace fs = std::filesystem;

nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
/// An effect's name, null for kNone.
nlohmann::json name_or_null(EffectKind k) {
  return k == EffectKind::kNone ? nlohmann::json(nullptr) : nlohmann::json(effect_name(k));
}

nlohmann::json parameters_json(const Effects& e, EffectKind kind) {
  nlohmann::json p = nlohmann::json::object();
  for (const auto& par : effect_parameters(kind)) {
    if (detail::omitted_when_zero(kind, par) && e.*(par.member) == 0.0) continue;
    p[par.name] = num(e.*(par.member));
  }
  return p;
}

/// The --json object: the first named effect (`effect`, `parameters`), the RMS before and after,
/// the first round's candidates, the names of the effects, and every named effect in `named`.
nlohmann::json result_json(const DiagnoseResult& res) {
  const EffectKind first = res.effects_named.empty() ? EffectKind::kNone : res.effects_named.front();
  nlohmann::json j;
  j["effect"] = effect_name(first);
  j["parameters"] = parameters_json(res.effects, first);
  j["error_before"] = num(res.error_before);
  j["error_after"] = num(res.error_after);
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& c : res.rounds.front().candidates) {
    cands.push_back({{"effect", effect_name(c.effect)}, {"score", num(c.score)},
                     {"error_after", num(c.error_after)}, {"inactive", c.inactive}});
  }
  j["candidates"] = cands;
  nlohmann::json names = nlohmann::json::array();
  for (EffectKind k : res.effects_named) names.push_back(effect_name(k));
  j["effects"] = names;
  // Every named effect in order with its parameters and the error over all runs after its round.
  nlohmann::json named = nlohmann::json::array();
  for (const NamedEffect& n : res.named_in_order()) {
    nlohmann::json entry = {{"effect", effect_name(n.effect)}, {"parameters", parameters_json(res.effects, n.effect)},
                            {"error_after", num(n.error_after)}};
    if (n.took_in != EffectKind::kNone) entry["took_in"] = effect_name(n.took_in);
    named.push_back(entry);
  }
  // The discovered term (tried when structure remained after the named effects): its terms,
  // the error after it, and whether it was kept (in the model) and carries the remainder.
  if (res.discovered && res.discovered->ok && !res.discovered->terms.empty()) {
    const DiscoveredTermResult& d = *res.discovered;
    nlohmann::json terms = nlohmann::json::array();
    for (const DiscoveredTermEntry& t : d.terms) {
      terms.push_back({{"name", t.name}, {"function", t.formula}, {"coefficient", num(t.coefficient)},
                       {"standard_error", num(t.standard_error)},
                       {"regression_coefficient", num(t.regression_coefficient)},
                       {"regression_standard_error", num(t.regression_standard_error)}});
    }
    nlohmann::json p = nlohmann::json::object();
    for (const DiscoveredTermEntry& t : d.terms) p[t.name] = num(t.coefficient);
    for (const auto& par : effect_parameters(EffectKind::kDiscovered, true)) {
      if (par.modelling_choice) p[par.name] = num(d.term_effects.*(par.member));
    }
    nlohmann::json entry = {{"effect", effect_name(EffectKind::kDiscovered)}, {"parameters", p},
                            {"terms", terms}, {"equation", d.equation}, {"reading", d.reading},
                            {"error_before", num(d.error_before)}, {"error_after", num(d.error_after)},
                            {"gap_closed", num(d.gap_closed)}, {"kept", d.kept},
                            {"structure_before", num(d.structure_before)},
                            {"structure_after", num(d.structure_after)},
                            {"structure_gap_closed", num(d.structure_gap_closed)},
                            {"memory_error_after", num(d.memory_error_after)},
                            {"took_in", name_or_null(d.took_in)},
                            {"took_in_tried", name_or_null(d.took_in_tried)},
                            {"took_in_error_after", num(d.took_in_error_after)},
                            {"took_in_structure_after", num(d.took_in_structure_after)},
                            {"carries_remainder", d.carries_remainder}};
    if (d.kept) named.push_back(entry);
    j["discovered"] = entry;
  } else if (res.discovered) {
    j["discovered"] = {{"effect", effect_name(EffectKind::kDiscovered)}, {"kept", false},
                       {"message", res.discovered->message}};
  }
  j["named"] = named;
  // The friction level run by run (run_levels.hpp; null: not tried): whether it differs between
  // runs (held out in time), each run's factor on the model's level, and what that changes.
  if (res.run_levels) {
    const RunLevelsResult& rl = *res.run_levels;
    nlohmann::json runs = nlohmann::json::array();
    for (const RunLevel& r : rl.runs) {
      runs.push_back({{"run", r.name}, {"factor", num(r.factor)}, {"standard_error", num(r.standard_error)},
                      {"rms_before", num(r.rms_before)}, {"rms_after", num(r.rms_after)}});
    }
    j["run_levels"] = {{"ok", rl.ok}, {"varies", rl.varies}, {"message", rl.message},
                       {"report", rl.brief_report()},
                       {"held_out_before", num(rl.held_out_before)}, {"held_out_after", num(rl.held_out_after)},
                       {"error_before", num(rl.error_before)}, {"error_after", num(rl.error_after)},
                       {"structure_before", num(rl.structure_before)}, {"structure_after", num(rl.structure_after)},
                       {"fundamental_before", num(rl.fundamental_before)},
                       {"fundamental_after", num(rl.fundamental_after)},
                       {"gap_closed", num(rl.gap_closed)}, {"structure_gap_closed", num(rl.structure_gap_closed)},
                       {"factor_min", num(rl.factor_min)}, {"factor_max", num(rl.factor_max)},
                       {"runs", runs}, {"seconds", num(rl.seconds)}};
  } else {
    j["run_levels"] = nullptr;
  }
  // The verdict on the final model against the noise floor estimated from the data.
  j["verdict"] = verdict_name(res.verdict.verdict);
  j["noise_floor"] = num(res.noise_floor.rms);
  // What the verdict judged: the structure (verdict.hpp structure_rms()) and the sine runs'
  // median error at the fundamental (null with fewer than three sine runs).
  j["structure_rms"] = num(res.verdict.structure_rms);
  j["fundamental_median"] = num(res.verdict.fundamental_median);
  const auto parts = [](const std::vector<UnexplainedPart>& list) {
    nlohmann::json out = nlohmann::json::array();
    for (const UnexplainedPart& u : list)
      out.push_back({{"where", u.where}, {"size", num(u.size)}, {"ratio", num(u.ratio)}});
    return out;
  };
  j["unexplained"] = parts(res.verdict.unexplained);
  // Above the ratio but not judged alone (verdict.hpp VerdictReport::not_judged).
  j["not_judged"] = parts(res.verdict.not_judged);
  // Candidates the data cannot tell from the named effects (separability.hpp).
  nlohmann::json not_separable = nlohmann::json::array();
  for (const NotSeparable& n : res.not_separable) {
    nlohmann::json from = nlohmann::json::array();
    for (EffectKind k : n.from) from.push_back(effect_name(k));
    not_separable.push_back({{"effect", effect_name(n.effect)}, {"from", from}, {"share", num(n.share)},
                             {"message", n.message}});
  }
  j["not_separable"] = not_separable;
  // Effects the rounds named and the model did without in the end (backward elimination).
  nlohmann::json dropped = nlohmann::json::array();
  for (const DroppedEffect& x : res.dropped) {
    dropped.push_back({{"effect", effect_name(x.effect)}, {"score_with", num(x.score_with)},
                       {"score_without", num(x.score_without)}, {"message", x.message}});
  }
  j["dropped"] = dropped;
  // The external_disturbance stage: the intervals located in time (the series: disturbance.csv).
  if (res.disturbance.tried) {
    const DisturbanceFinding& f = res.disturbance;
    nlohmann::json iv = nlohmann::json::array();
    for (std::size_t i = 0; i < f.runs.size(); ++i) {
      for (const DisturbanceInterval& x : f.runs[i].intervals)
        iv.push_back({{"run", f.run_names[i]}, {"start_s", num(x.start_s)}, {"end_s", num(x.end_s)},
                      {"level_v", num(x.level_v)}});
    }
    nlohmann::json recorded = nlohmann::json::array();
    for (std::size_t i = 0; i < f.recorded.size(); ++i)
      if (f.recorded[i]) recorded.push_back(f.run_names[i]);
    // Per run: how its windows were judged (why nothing was located there, when so).
    nlohmann::json per_run = nlohmann::json::array();
    for (std::size_t i = 0; i < f.runs.size(); ++i) {
      const DisturbanceEstimate& r = f.runs[i];
      per_run.push_back({{"run", f.run_names[i]}, {"ok", r.ok}, {"windows", r.windows},
                         {"active_windows", r.active_windows}, {"baseline_v", num(r.baseline_v)},
                         {"spread_v", num(r.spread_v)}, {"intervals", r.intervals.size()},
                         {"position_part_removed", r.position_part_removed},
                         {"message", r.message}});
    }
    j["disturbance"] = {{"named", f.named}, {"message", f.message}, {"rms_v", num(f.rms_v)},
                        {"error_before", num(f.error_before)}, {"error_after", num(f.error_after)},
                        {"touched_before", num(f.touched_before)}, {"touched_after", num(f.touched_after)},
                        {"intervals", iv}, {"recorded_disturbance_v", recorded}, {"runs", per_run}};
  }
  return j;
}

/// Residual figures: θ − θ_sim before and after for the worst runs (at most 3).
std::string residual_figures(const fs::path& out, const std::vector<DiagnoseRun>& runs,
                             const std::vector<DiagnoseRun>& runs_after, const DiagnoseResult& r, const SimulationOptions& sim,
                             const Effects& effects_before, const std::string& unit,
                             std::string& warning) {
  const fs::path dir = out / "plots";
  fs::create_directories(dir);
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (std::isfinite(r.before.run_rms[i])) order.push_back(i);
  }
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return r.before.run_rms[a] > r.before.run_rms[b]; });
  if (order.size() > 3) order.resize(3);
  const auto before = simulate_diagnosed(runs, effects_before, ModelScales{}, sim, 0);
  const auto after = simulate_diagnosed(runs_after, r.effects, r.scales, sim, 0, r.alpha);
  std::ostringstream md;
  md << "\n## Residual before and after\n\n";
  int n = 0;
  for (std::size_t i : order) {
    const std::string id = "residual_run" + std::to_string(++n);
    const RunData& d = *runs[i].data;
    {
      std::ofstream dat(dir / (id + ".dat"));
      dat << "# t [s]  residual before  residual after [position unit]  (θ − θ_sim), run "
          << runs[i].name << "\n";
      for (std::size_t k = 0; k < d.size(); ++k) {
        const double b = before[i].size() == d.size() ? d.theta[k] - before[i][k] : NAN;
        const double a = after[i].size() == d.size() ? d.theta[k] - after[i][k] : NAN;
        dat << d.t[k] << " " << b << " " << a << "\n";
      }
    }
    const std::string caption = "θ − θ_sim of " + runs[i].name + " before and after the diagnosis";
    {
      std::ofstream gp(dir / (id + ".gp"));
      gp << gnuplot_preamble(id, caption, 900, 420)
         << "set termoption noenhanced\n"  // file names and θ_sim as written
         << "set title " << gnuplot_quote(caption) << "\nset xlabel 'time t [s]'\nset ylabel "
         << gnuplot_quote("θ − θ_sim [" + unit + "]") << "\n"
         << "plot '" << id << ".dat' using 1:2 with lines lc rgb '#1f77b4' title 'before', \\\n"
         << "     '' using 1:3 with lines lc rgb '#d62728' title 'after'\n";
    }
    const std::string why = draw_gnuplot_figure("gnuplot", dir, id);
    if (!why.empty()) {
      warning = "figures not drawn: " + why;
      md << "- " << caption << ": not drawn (" << why << "); data and script in plots/" << id
         << ".{dat,gp}\n";
    } else {
      md << "![" << id << "](plots/" << id << ".png)\n\n*" << caption << ".*\n\n";
    }
  }
  return md.str();
}

}  // namespace

CLI::App* add_diagnose_subcommand(CLI::App& app, DiagnoseCommandOptions& o) {
  auto* c = app.add_subcommand(
      "diagnose", "find where simulation and measurement disagree, name the missing effect, add it");
  c->add_option("dataset", o.dataset_dir, "dataset folder (alphainv-dataset/1)")->required();
  c->add_option("--model", o.model_path, "model.json to diagnose (default: fit the dataset first)");
  c->add_option("-o,--out", o.out_dir, "output folder: report.md, model.json with the effect, plots/");
  c->add_flag("--json", o.json, "print one JSON object to stdout");
  c->add_flag("-q,--quiet", o.quiet, "print nothing but errors");
  c->add_flag("--no-plots", o.no_plots, "no residual figures");
  c->add_flag("--no-discover", o.no_discover,
              "no discovered term (sparse regression on a library) after the named effects");
  c->add_option("--max-effects", o.max_effects,
                 "rounds: effects to name at most (rounds go on while an effect is named and "
                 "structure remains above the noise floor)")
      ->capture_default_str()->check(CLI::Range(1, 7));
  c->add_option("--threads", o.threads, "threads (default: all cores)");
  c->add_option("--fit-runs", o.max_fit_runs, "runs used to fit and score the candidates")
      ->capture_default_str()->check(CLI::Range(2, 1000));
  c->footer(
      "Effects: " + effect_names_text() + ".\n"
      "Examples:\n  omni_fit diagnose data/omni_yaw_sim -o out/diag --json\n"
      "  omni_fit diagnose run_dir --model out/fit/model.json --max-effects 2 -o out/diag\n"
      "Exit codes: 0 ok (also when it names none), 1 usage, 2 bad input (names the file), "
      "3 nothing could be diagnosed.");
  return c;
}

int run_diagnose(const DiagnoseCommandOptions& o) {
  Dataset ds;
  std::vector<RunData> data;
  try {
    ds = read_dataset_index(o.dataset_dir);
    for (std::size_t i = 0; i < ds.runs.size(); ++i) data.push_back(read_run(ds, i));
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_fit diagnose: %s\n", e.what());
    return 2;
  }
  // The output goes to a sibling folder swapped into place at the end (common/output_folder.hpp).
  std::optional<common::OutputFolder> folder;
  if (!o.out_dir.empty()) {
    try {
      folder.emplace(o.out_dir,
                     std::initializer_list<const char*>{"model.json", "report.md", "plots",
                                                        "disturbance.csv"});
    } catch (const Error& e) {
      std::fprintf(stderr, "omni_fit diagnose: -o: %s\n", e.what());
      return 2;
    }
  }
  DiagnoseOptions dopt;
  dopt.max_effects = o.max_effects;
  dopt.threads = o.threads;
  dopt.max_fit_runs = o.max_fit_runs;
  dopt.discover = !o.no_discover;
  ModelFile model;
  std::vector<DiagnoseRun> runs;
  std::string model_source;
  DiagnoseResult res;
  if (!o.model_path.empty()) {
    try {
      model = read_model_file(o.model_path);
      runs = diagnose_runs(ds, data, model);
    } catch (const Error& e) {
      std::fprintf(stderr, "omni_fit diagnose: %s\n", e.what());
      return 2;
    }
    dopt.simulation.loop_period_s = model.loop_period_s;
    model_source = "`" + o.model_path + "`";
    res = diagnose(runs, dopt);
  } else {
    FitPipelineOptions fo;
    fo.threads = o.threads;
    DatasetFit fit;
    res = diagnose_dataset(ds, data, dopt, fo, &fit);
    dopt.simulation = fit.simulation;
    runs = diagnose_runs(ds, data, fit);
    try {
      model = fit_model_file(ds, fit);
    } catch (const Error& e) {
      std::fprintf(stderr, "omni_fit diagnose: %s\n", e.what());
      return 2;
    }
    model_source = "fitted by omni_fit fit's pipeline";
  }
  if (!res.ok) {
    std::fprintf(stderr, "omni_fit diagnose: nothing could be diagnosed in %s: %s\n",
                 o.dataset_dir.c_str(), res.message.c_str());
    return 3;
  }
  const Effects effects_before = runs.empty() ? Effects{} : runs.front().model.effects;
  if (folder) {
    const fs::path out = folder->path();  // swapped into place at the end
    try {
      ModelFile m = model;
      apply_diagnosis(m, res);
      write_model_file(out / "model.json", m);
      std::string warning;
      // (after: with the located disturbance known, as diagnose simulated it)
      std::vector<RunData> with_d;
      const std::vector<DiagnoseRun> runs_after = with_located_disturbance(runs, res.disturbance, with_d);
      const std::string figs =
          o.no_plots ? std::string()
                     : residual_figures(out, runs, runs_after, res, dopt.simulation, effects_before,
                                        ds.position_unit, warning);
      if (res.disturbance.named) {
        write_text_atomic(out / "disturbance.csv", disturbance_csv(res.disturbance, runs));
      }
      if (!warning.empty() && !o.quiet) std::fprintf(stderr, "omni_fit diagnose: %s\n", warning.c_str());
      write_text_atomic(out / "report.md",
                        diagnose_report_markdown(res, runs, o.dataset_dir, model_source) + figs);
      folder->commit();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "omni_fit diagnose: writing %s: %s\n", o.out_dir.c_str(), e.what());
      return 2;
    }
  }
  if (o.json) {
    std::printf("%s\n", result_json(res).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  } else if (!o.quiet) {
    std::printf("omni_fit diagnose: %s\n", res.brief_report().c_str());
    for (const auto& f : res.before.findings) std::printf("  before: %s\n", f.c_str());
    for (EffectKind k : res.effects_named)
      std::printf("  %s: %s\n", effect_name(k), effect_parameters_text(res.effects, k).c_str());
    std::printf("  verdict: %s\n", res.verdict.text().c_str());
    if (res.discovered) std::printf("  %s\n", res.discovered->brief_report().c_str());
    if (res.discovered && res.discovered->kept)
      std::printf("  %s\n", discovered_verdict_text(*res.discovered).c_str());
    if (res.run_levels) std::printf("  friction level run by run: %s\n", res.run_levels->brief_report().c_str());
    for (const NotSeparable& n : res.not_separable) std::printf("  not separable: %s\n", n.message.c_str());
    for (const DroppedEffect& x : res.dropped) std::printf("  dropped: %s\n", x.message.c_str());
  }
  return 0;
}

}  // namespace omni_fit
