/// \file bind_work.cpp
/// The work in Python: simulate (model_simulation.hpp), fit (fit_pipeline.hpp, refine_effects),
/// diagnose (diagnose.hpp) and validate (validation.hpp). Each releases the GIL while the library
/// works and returns a result object with its figures, its model, its report text and to_dict().

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/diagnose/diagnose_report.hpp"
#include "alphainv/diagnose/diagnosed_model_file.hpp"
#include "alphainv/diagnose/discovered_term.hpp"
#include "alphainv/diagnose/run_levels.hpp"
#include "alphainv/diagnose/verdict.hpp"
#include "alphainv/diagnose/effect_refinement.hpp"
#include "alphainv/identify/fit_model_file.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
#include "alphainv/identify/fit_report.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/identify/validation.hpp"
#include "alphainv/simulate/model_simulation.hpp"
#include "bindings.hpp"

namespace alphainv::python {

namespace {

py::object num(double x) { return std::isfinite(x) ? py::object(py::float_(x)) : py::object(py::none()); }
/// An effect's name, None for kNone.
py::object name_or_none(EffectKind k) {
  return k == EffectKind::kNone ? py::object(py::none()) : py::object(py::str(effect_name(k)));
}

/// A model argument: a Model, anything with a `.model` (a fit or a diagnosis), or a path.
ModelFile model_argument(py::handle obj) {
  if (py::isinstance<ModelFile>(obj)) return obj.cast<ModelFile>();
  if (py::isinstance<py::str>(obj) || py::hasattr(obj, "__fspath__"))
    return read_model_file(py::str(py::module_::import("os").attr("fspath")(obj)).cast<std::string>());
  if (py::hasattr(obj, "model")) return obj.attr("model").cast<ModelFile>();
  throw Error("expected an alphainv.Model, a fit or diagnosis result, or a model.json path", {}, 0, "model");
}

/// The `omni_fit fit --json` names of one model's errors.
py::dict errors_dict(const ModelErrors& e) {
  py::dict d;
  d["step_median_abs_err"] = num(e.step_median_abs_err);
  d["step_p90_abs_err"] = num(e.step_p90_abs_err);
  d["phase_p90_deg"] = num(e.phase_p90_deg);
  d["magnitude_p90"] = num(e.magnitude_p90);
  d["rel_position_error_median"] = num(e.rel_position_error_median);
  return d;
}

py::dict fit_figures_dict(const FitFigures& f) {
  py::dict d;
  d["n"] = f.n, d["rms"] = num(f.rms), d["max_abs"] = num(f.max_abs);
  d["fit_percent"] = num(f.fit_percent), d["relative_error"] = num(f.relative_error);
  return d;
}

/// Calls a Python progress callback from any thread (the GIL taken); keeps its first exception
/// for the caller to raise after the library returns.
struct Progress {
  PyObject* callback = nullptr;  // borrowed: the caller holds the object
  std::unique_ptr<py::error_already_set> error;
  std::function<void(std::string_view, std::size_t, std::size_t)> function() {
    if (!callback) return {};
    return [this](std::string_view stage, std::size_t done, std::size_t total) {
      py::gil_scoped_acquire gil;
      if (error) return;
      try {
        const py::handle cb(callback);
        cb(py::str(std::string(stage)), done, total);
      } catch (py::error_already_set& e) {
        error = std::make_unique<py::error_already_set>(std::move(e));
      }
    };
  }
  void rethrow() {
    if (error) {
      error->restore();
      error.reset();
      throw py::error_already_set();
    }
  }
};

// --- fit ------------------------------------------------------------------------------------------

struct FitOutcome {
  DatasetPtr data;
  DatasetFit fit;
  ModelFile model;
  bool refined = false;
  EffectRefinement refinement;

  std::size_t pose_of_run(std::size_t run) const {
    for (std::size_t p = 0; p < fit.poses.size(); ++p)
      for (std::size_t i : fit.poses[p].runs)
        if (i == run) return p;
    throw Error("run " + std::to_string(run) + " is in no pose of the fit", {}, 0, "run");
  }
  py::dict figures() const {
    py::dict j;
    j["runs"] = data->index.runs.size();
    j["poses"] = fit.poses.size();
    j["linear"] = errors_dict(fit.linear_errors);
    j["alpha"] = errors_dict(fit.alpha_errors);
    const double ratio = fit.alpha_errors.step_median_abs_err > 0.0
                             ? fit.linear_errors.step_median_abs_err / fit.alpha_errors.step_median_abs_err
                             : std::nan("");
    j["step_error_ratio"] = num(ratio);
    return j;
  }
  py::dict sine_points() const {
    std::vector<double> run, pose, f, a, c, b, bt, g, ph, phys;
    for (const SineRunPoint& s : fit.sine_points) {
      run.push_back(static_cast<double>(s.run)), pose.push_back(static_cast<double>(s.pose));
      f.push_back(s.point.freq_hz), a.push_back(s.point.alpha_data), c.push_back(s.point.c_data);
      b.push_back(s.point.beta_data), bt.push_back(fit.kp > 0.0 ? s.point.beta_data / fit.kp : std::nan(""));
      g.push_back(s.gain), ph.push_back(s.phase_deg), phys.push_back(s.point.physical ? 1.0 : 0.0);
    }
    py::dict d;
    d["run"] = to_array(run).attr("astype")("int64");
    d["pose"] = to_array(pose).attr("astype")("int64");
    d["freq_hz"] = to_array(f), d["alpha_data"] = to_array(a), d["c_data"] = to_array(c);
    d["beta_data"] = to_array(b), d["beta_tilde_data"] = to_array(bt), d["gain"] = to_array(g);
    d["phase_deg"] = to_array(ph), d["physical"] = to_array(phys).attr("astype")("bool");
    return d;
  }
  py::dict alpha_fit() const {
    const AlphaFitResult& a = fit.alpha;
    py::dict d;
    d["ok"] = a.ok, d["message"] = a.message, d["source"] = fit.alpha_source;
    d["c_rms_relative"] = num(a.c_rms_relative), d["beta_rms_relative"] = num(a.beta_rms_relative);
    d["points_used"] = a.points_used, d["refined"] = a.refined;
    d["alpha_data_min"] = num(a.alpha_data_min), d["alpha_data_max"] = num(a.alpha_data_max);
    return d;
  }
  py::list poses() const {
    py::list out;
    for (const PoseFit& p : fit.poses) {
      py::dict d;
      d["gamma1_deg"] = optional_number(p.gamma1_deg), d["gamma2_deg"] = optional_number(p.gamma2_deg);
      d["runs"] = p.runs, d["inertia"] = p.inertia, d["linear_source"] = p.linear_source;
      d["c_linear"] = num(p.linear.c_linear), d["beta_tilde_linear"] = num(p.linear.beta_tilde_linear);
      d["linear_valid"] = p.linear.valid;
      d["linear_errors"] = errors_dict(p.linear_errors), d["alpha_errors"] = errors_dict(p.alpha_errors);
      out.append(d);
    }
    return out;
  }
  std::string markdown() const {
    FitReportInfo info;
    info.dataset_hash = model.dataset_hash;
    return fit_report_markdown(data->index, fit, info);
  }
  /// Run i simulated with the linear and the α-model of its pose as the validation does
  /// (from the measured initial state under the run's controller and reference).
  py::dict simulate_run(std::size_t i) const {
    if (i >= data->runs.size()) throw Error("no run " + std::to_string(i), {}, 0, "run");
    const RunData& d = data->runs[i];
    JointModelAtPose m = fit.model_for_pose(pose_of_run(i));
    std::vector<double> lin(d.size(), std::nan("")), alp(d.size(), std::nan(""));
    std::string message;
    {
      py::gil_scoped_release release;
      const SampledReference ref(d.t, d.r);
      const InitialState x0 = initial_state_of(d);
      const Controller ctl = data->index.runs[i].controller;
      if (m.c_linear > 0.0 && m.beta_tilde_linear > 0.0) {
        m.use_alpha = false;
        const SimulationResult l = simulate(m, ctl, ref, d.t, x0, fit.simulation);
        if (l.ok) lin = l.theta; else message = "linear: " + l.message;
      } else {
        message = "no linear model at this run's pose";
      }
      if (fit.alpha.ok) {
        m.use_alpha = true;
        const SimulationResult a = simulate(m, ctl, ref, d.t, x0, fit.simulation);
        if (a.ok) alp = a.theta; else message += (message.empty() ? "" : "; ") + ("alpha: " + a.message);
      }
    }
    py::dict out;
    out["t"] = to_array(d.t), out["r"] = to_array(d.r), out["theta"] = to_array(d.theta);
    out["theta_linear"] = to_array(lin), out["theta_alpha"] = to_array(alp);
    out["message"] = message;
    return out;
  }
  py::dict to_dict() const {
    py::dict d;
    d["usable"] = fit.usable(), d["message"] = fit.message, d["brief_report"] = fit.brief_report();
    d["figures"] = figures();
    d["model"] = json_loads(format_model_file(model));
    d["notes"] = fit.notes;
    const KnownDisturbanceCorrection& dc = fit.disturbance_correction;
    py::dict dist;  // the names of `omni_fit fit --json` "disturbance_correction"
    dist["runs_with_disturbance"] = dc.runs_with_disturbance;
    dist["runs_corrected"] = dc.runs_corrected;
    dist["passes"] = dc.passes, dist["last_point_change"] = dc.last_point_change;
    dist["chosen_pass"] = dc.chosen_pass, dist["first_pass_rms"] = dc.first_pass_rms_rad;
    dist["chosen_rms"] = dc.chosen_rms_rad;
    d["disturbance_correction"] = dist;
    py::dict pts;
    for (auto item : sine_points()) pts[item.first] = item.second.attr("tolist")();
    d["sine_points"] = pts;
    d["poses"] = poses();
    d["alpha_fit"] = alpha_fit();
    d["report"] = fit.full_report();
    if (refined) {
      py::dict r;
      r["ok"] = refinement.ok, r["message"] = refinement.message;
      r["sse_start"] = refinement.sse_start, r["sse_refined"] = refinement.sse_refined;
      r["effects"] = effects_dict(refinement.refined);
      d["refinement"] = r;
    }
    return d;
  }
};

FitPipelineOptions fit_options(Options& o, Progress* progress) {
  FitPipelineOptions p;
  o.get("settle_fraction", p.settle_fraction);
  o.get("n_breakpoints", p.n_breakpoints);
  o.get("threads", p.threads);
  o.get("run_validation", p.run_validation);
  o.get("time_domain", p.time_domain);
  o.get("loop_period_s", p.loop_period_s);
  o.get("refine_breakpoints", p.refine_breakpoints);
  o.get("alpha_consistent_inertia", p.alpha_consistent_inertia);
  o.get("disturbance_passes", p.disturbance_passes);
  o.get_effects("effects", p.effects);
  if (progress) {
    py::object cb = o.raw("progress");
    if (!cb.is_none()) {
      if (!PyCallable_Check(cb.ptr())) throw Error("expected a callable (stage, done, total)", {}, 0, "progress");
      progress->callback = cb.ptr();
    }
  }
  p.validate();
  return p;
}

FitOutcome run_fit(py::handle dataset, py::kwargs kwargs) {
  Options o(std::move(kwargs), "fit");
  Progress progress;
  py::object keep_callback = o.raw("progress");  // holds the callback while the fit runs
  FitPipelineOptions popt = fit_options(o, &progress);
  bool refine = false;
  o.get("refine_effects", refine);
  o.finish();
  if (refine && active_effects(popt.effects).empty())
    throw Error("refine_effects needs known effects (effects=...)", {}, 0, "refine_effects");
  FitOutcome out;
  out.data = dataset_argument(dataset);
  out.refined = refine;
  popt.progress = progress.function();
  {
    py::gil_scoped_release release;
    out.fit = refine ? refine_effects(out.data->index, out.data->runs, popt, &out.refinement)
                     : fit_dataset(out.data->index, out.data->runs, popt);
    popt.progress = nullptr;
  }
  progress.rethrow();
  out.model = fit_model_file(out.data->index, out.fit);
  return out;
}

// --- diagnose -------------------------------------------------------------------------------------

struct DiagnoseOutcome {
  DatasetPtr data;
  DiagnoseResult result;
  ModelFile model;
  std::string markdown;

  static py::dict candidate(const CandidateScore& c) {
    py::dict d;
    d["effect"] = effect_name(c.effect), d["ok"] = c.ok, d["message"] = c.full_message();
    d["score"] = num(c.score), d["fold_scores"] = py::make_tuple(num(c.fold_scores[0]), num(c.fold_scores[1]));
    d["error_after"] = num(c.error_after), d["training_rms"] = num(c.training_rms);
    d["cross_validated"] = c.cross_validated, d["reidentified"] = c.reidentified;
    d["inactive"] = c.inactive;
    d["parameters"] = effect_parameters_text(c.effects, c.effect);
    d["effects"] = effects_dict(c.effects);
    return d;
  }
  static py::dict location(const ResidualLocation& l) {
    py::dict d;
    d["rms"] = num(l.rms), d["run_rms"] = to_array(l.run_rms).attr("tolist")();
    d["reversal_concentration"] = num(l.reversal_concentration);
    d["jump_concentration"] = num(l.jump_concentration);
    d["high_command_concentration"] = num(l.high_command_concentration);
    d["low_command_concentration"] = num(l.low_command_concentration);
    d["high_alpha_concentration"] = num(l.high_alpha_concentration);
    d["position_r2"] = num(l.position_r2), d["low_vs_high_frequency"] = num(l.low_vs_high_frequency);
    d["findings"] = l.findings;
    return d;
  }
  py::list effects_named() const {
    py::list out;
    for (EffectKind k : result.effects_named) out.append(effect_name(k));
    return out;
  }
  py::dict figures() const {
    py::dict d;
    const EffectKind first = result.effects_named.empty() ? EffectKind::kNone : result.effects_named.front();
    d["effect"] = effect_name(first);
    d["effects"] = effects_named();
    d["error_before"] = num(result.error_before), d["error_after"] = num(result.error_after);
    d["seconds"] = result.seconds;
    py::list cands;
    if (!result.rounds.empty())
      for (const CandidateScore& c : result.rounds.front().candidates) cands.append(candidate(c));
    d["candidates"] = cands;
    return d;
  }
  py::list rounds() const {
    py::list out;
    for (const DiagnoseRound& r : result.rounds) {
      py::dict d;
      d["named"] = effect_name(r.named), d["error_before"] = num(r.error_before), d["error_after"] = num(r.error_after);
      d["named_second"] = effect_name(r.named_second);  // the pair fallback's second effect
      py::list pairs;
      for (const PairScore& p : r.pairs) {
        py::dict pd = candidate(p.fit);
        pd["kinds"] = py::make_tuple(effect_name(p.kinds[0]), effect_name(p.kinds[1]));
        pd["parameters"] = effect_parameters_text(p.fit.effects, p.kinds[0]) + "; " +
                           effect_parameters_text(p.fit.effects, p.kinds[1]);
        pd["named"] = p.named;
        pd["dropped"] = effect_name(p.dropped);  // a member that added nothing ("none": both kept)
        pd["refined_from"] = effect_name(p.refined_from);  // the member this pair has in a general form ("none")
        pairs.append(pd);
      }
      d["pairs"] = pairs;
      py::list cands;
      for (const CandidateScore& c : r.candidates) cands.append(candidate(c));
      d["candidates"] = cands;
      d["none_at_winner_breakpoints"] = r.none_at_winner_breakpoints ? py::object(candidate(*r.none_at_winner_breakpoints)) : py::object(py::none());
      d["none_at_runner_up_breakpoints"] = r.none_at_runner_up_breakpoints ? py::object(candidate(*r.none_at_runner_up_breakpoints)) : py::object(py::none());
      d["none_across_gap"] = r.none_across_gap ? py::object(candidate(*r.none_across_gap)) : py::object(py::none());
      d["none_refitted"] = r.none_refitted;
      d["none_refit_how"] = r.none_refit_how;
      d["after_dropping"] = r.after_dropping;  // run in a place the backward elimination freed
      d["took_in"] = effect_name(r.took_in);  // "none": it took in no earlier round's effect
      // A member named on trial: the RMS over all runs the diagnosis had to end below (None: none).
      d["on_trial_reference_rms"] = num(r.on_trial_reference_rms);
      d["rolled_back"] = r.rolled_back;  // its effects are not in the result
      d["rolled_back_why"] = r.rolled_back_why;
      out.append(d);
    }
    return out;
  }
  py::dict to_dict() const {
    py::dict d;
    d["ok"] = result.ok, d["message"] = result.message, d["termination"] = termination_name(result.termination);
    d["brief_report"] = result.brief_report();
    d["figures"] = figures();
    d["effects"] = effects_dict(result.effects);
    d["rounds"] = rounds();
    d["before"] = location(result.before), d["after"] = location(result.after);
    d["model"] = result.ok ? json_loads(format_model_file(model)) : py::object(py::none());
    d["not_separable"] = not_separable();
    d["dropped"] = dropped();
    d["named"] = named(), d["verdict"] = verdict(), d["discovered"] = discovered();
    d["run_levels"] = run_levels();
    d["report"] = result.full_report();
    return d;
  }
  /// DiagnoseResult::named_in_order(): every named effect in order (as omni_fit diagnose --json's
  /// `named`, without the discovered term: `discovered`).
  py::list named() const {
    py::list out;
    for (const NamedEffect& n : result.named_in_order()) {
      py::dict d;
      d["effect"] = effect_name(n.effect), d["error_after"] = num(n.error_after);
      d["parameters"] = effect_parameters_text(result.effects, n.effect);
      d["took_in"] = effect_name(n.took_in);
      out.append(d);
    }
    return out;
  }
  /// The verdict on the final model against the noise floor (verdict.hpp).
  py::dict verdict() const {
    const VerdictReport& v = result.verdict;
    py::dict d;
    d["verdict"] = verdict_name(v.verdict), d["text"] = v.text();
    d["noise_floor"] = num(result.noise_floor.rms);
    d["noise_floor_cycle_to_cycle"] = num(result.noise_floor.cycle_to_cycle);
    d["structure_rms"] = num(v.structure_rms), d["fundamental_median"] = num(v.fundamental_median);
    const auto parts = [](const std::vector<UnexplainedPart>& list) {
      py::list out;
      for (const UnexplainedPart& u : list) {
        py::dict p;
        p["where"] = u.where, p["size"] = num(u.size), p["ratio"] = num(u.ratio);
        out.append(p);
      }
      return out;
    };
    d["unexplained"] = parts(v.unexplained);
    d["not_judged"] = parts(v.not_judged);  // above the ratio, not judged alone
    d["before"] = verdict_name(result.verdict_before.verdict);  // on the model given
    return d;
  }
  /// The discovered term tried after the named effects; None when not tried.
  py::object discovered() const {
    if (!result.discovered) return py::none();
    const DiscoveredTermResult& t = *result.discovered;
    py::dict d;
    d["ok"] = t.ok, d["kept"] = t.kept, d["message"] = t.message;
    d["equation"] = t.equation, d["reading"] = t.reading;
    py::list terms;
    for (const DiscoveredTermEntry& e : t.terms) {
      py::dict x;
      x["name"] = e.name, x["function"] = e.formula;
      x["coefficient"] = num(e.coefficient), x["standard_error"] = num(e.standard_error);
      terms.append(x);
    }
    d["terms"] = terms;
    d["error_before"] = num(t.error_before), d["error_after"] = num(t.error_after);
    d["gap_closed"] = num(t.gap_closed), d["structure_gap_closed"] = num(t.structure_gap_closed);
    d["carries_remainder"] = t.carries_remainder;
    // the named effect it took the place of (None: none)
    d["took_in"] = name_or_none(t.took_in);
    // the named friction whose place was tried (the best such contender), and its RMS (None: none tried)
    d["took_in_tried"] = name_or_none(t.took_in_tried);
    d["took_in_error_after"] = num(t.took_in_error_after);
    d["took_in_structure_after"] = num(t.took_in_structure_after);
    return d;
  }
  /// The friction level fitted run by run (run_levels.hpp); None when not tried.
  py::object run_levels() const {
    if (!result.run_levels) return py::none();
    const RunLevelsResult& t = *result.run_levels;
    py::dict d;
    d["ok"] = t.ok, d["varies"] = t.varies, d["message"] = t.message, d["report"] = t.brief_report();
    d["held_out_before"] = num(t.held_out_before), d["held_out_after"] = num(t.held_out_after);
    d["error_before"] = num(t.error_before), d["error_after"] = num(t.error_after);
    d["structure_before"] = num(t.structure_before), d["structure_after"] = num(t.structure_after);
    d["gap_closed"] = num(t.gap_closed), d["structure_gap_closed"] = num(t.structure_gap_closed);
    d["factor_min"] = num(t.factor_min), d["factor_max"] = num(t.factor_max);
    py::list runs;
    for (const RunLevel& r : t.runs) {
      py::dict x;
      x["run"] = r.name, x["factor"] = num(r.factor), x["standard_error"] = num(r.standard_error);
      x["rms_before"] = num(r.rms_before), x["rms_after"] = num(r.rms_after);
      runs.append(x);
    }
    d["runs"] = runs;
    return d;
  }
  /// DiagnoseResult::not_separable: the candidates the data cannot tell from the named effects.
  py::list not_separable() const {
    py::list out;
    for (const NotSeparable& n : result.not_separable) {
      py::dict d;
      d["effect"] = effect_name(n.effect);
      py::list from;
      for (EffectKind k : n.from) from.append(effect_name(k));
      d["from"] = from, d["share"] = n.share, d["message"] = n.message;
      out.append(d);
    }
    return out;
  }
  /// DiagnoseResult::dropped: effects the rounds named that the model did without in the end.
  py::list dropped() const {
    py::list out;
    for (const DroppedEffect& x : result.dropped) {
      py::dict d;
      d["effect"] = effect_name(x.effect);
      d["score_with"] = x.score_with, d["score_without"] = x.score_without, d["message"] = x.message;
      out.append(d);
    }
    return out;
  }
};

DiagnoseOutcome run_diagnose(py::handle dataset, py::object model_obj, py::kwargs kwargs) {
  Options o(std::move(kwargs), "diagnose");
  DiagnoseOptions dopt;
  o.get("max_effects", dopt.max_effects);
  o.get("threads", dopt.threads);
  o.get("max_fit_runs", dopt.max_fit_runs);
  o.get("max_residuals_per_run", dopt.max_residuals_per_run);
  o.get("fit_window_s", dopt.fit_window_s);
  o.get("significance", dopt.significance);
  o.get("reidentify", dopt.reidentify);
  o.get("discover", dopt.discover);
  py::object cands = o.raw("candidates");
  if (!cands.is_none()) {
    std::size_t k = 0;
    for (auto c : cands.cast<py::sequence>())
      dopt.candidates.push_back(effect_kind_from_name(py::cast<std::string>(c), "candidates[" + std::to_string(k++) + "]"));
  }
  py::object fit_kw = o.raw("fit_options");
  o.finish();
  Options fo_reader(fit_kw.is_none() ? py::kwargs() : py::kwargs(fit_kw.cast<py::dict>()), "diagnose fit_options");
  FitPipelineOptions fo = fit_options(fo_reader, nullptr);
  fo_reader.finish();
  dopt.validate();
  DiagnoseOutcome out;
  out.data = dataset_argument(dataset);
  const Dataset& ds = out.data->index;
  const std::vector<RunData>& data = out.data->runs;
  std::vector<DiagnoseRun> runs;
  std::string model_source;
  if (!model_obj.is_none()) {
    out.model = model_argument(model_obj);
    runs = diagnose_runs(ds, data, out.model);
    dopt.simulation.loop_period_s = out.model.loop_period_s;
    model_source = "the model given";
    py::gil_scoped_release release;
    out.result = diagnose(runs, dopt);
  } else {
    DatasetFit fit;
    {
      py::gil_scoped_release release;
      out.result = diagnose_dataset(ds, data, dopt, fo, &fit);
    }
    dopt.simulation = fit.simulation;
    runs = diagnose_runs(ds, data, fit);
    model_source = "fitted by omni_fit fit's pipeline";
    if (out.result.ok) out.model = fit_model_file(ds, fit);
  }
  if (out.result.ok) {
    apply_diagnosis(out.model, out.result);
    out.markdown = diagnose_report_markdown(out.result, runs, ds.dir.empty() ? std::string("(in memory)") : ds.dir.string(),
                                            model_source);
  }
  return out;
}

// --- validate -------------------------------------------------------------------------------------

py::dict run_dict(const ValidatedRun& r) {
  py::dict d;
  d["file"] = r.file, d["ok"] = r.ok, d["message"] = r.message, d["first_sample"] = r.first_sample;
  d["position"] = fit_figures_dict(r.position), d["command"] = fit_figures_dict(r.command);
  d["white"] = r.residual.white, d["input_correlated"] = r.residual.input_correlated;
  d["residual_valid"] = r.residual.valid;
  d["verdict"] = r.residual.valid ? r.residual.verdict() : r.residual.message;
  return d;
}

py::dict validation_figures(const ValidationResult& v) {
  py::dict d;
  d["position"] = fit_figures_dict(v.position), d["command"] = fit_figures_dict(v.command);
  d["runs"] = v.runs.size(), d["runs_white"] = v.runs_white;
  d["runs_input_correlated"] = v.runs_input_correlated, d["runs_tested"] = v.runs_tested;
  d["seconds"] = v.seconds;
  return d;
}

// --- simulate -------------------------------------------------------------------------------------

struct SimulationOutcome {
  DatasetPtr data;  ///< the simulated run as a one-run dataset
  ModelFile model;
  bool ok = false;
  std::string message, note;
  py::dict figures() const {
    py::dict d;
    if (!ok || data->runs.empty() || data->runs[0].size() == 0) return d;
    const RunData& r = data->runs[0];
    const auto [lo, hi] = std::minmax_element(r.theta.begin(), r.theta.end());
    d["samples"] = r.size(), d["duration_s"] = r.t.back() - r.t.front();
    d["theta_min"] = *lo, d["theta_max"] = *hi;
    const auto it = r.extra_columns.find("alpha");
    if (it != r.extra_columns.end() && !it->second.empty()) {
      double s = 0.0;
      for (double a : it->second) s += a;
      d["alpha_mean"] = s / static_cast<double>(it->second.size());
      d["alpha_max"] = *std::max_element(it->second.begin(), it->second.end());
    }
    return d;
  }
  std::string report() const {
    if (!ok) return "simulation failed: " + message;
    const RunData& r = data->runs[0];
    const RunInfo& i = data->index.runs[0];
    return "simulated " + i.kind + " " + report_number(i.freq_hz.value_or(std::nan(""))) + " Hz, " +
           std::to_string(r.size()) + " samples; " + note;
  }
};

SimulationOutcome run_simulate(py::handle model_obj, py::object pose, const std::string& reference, py::kwargs kwargs) {
  Options o(std::move(kwargs), "simulate");
  ModelRunOptions opt;
  if (reference == "sine") opt.reference = ModelRunReference::kSine;
  else if (reference == "square") opt.reference = ModelRunReference::kSquare;
  else throw Error("expected \"sine\" or \"square\", found \"" + reference + "\"", {}, 0, "reference");
  o.get("freq_hz", opt.freq_hz);
  o.get("amplitude_rad", opt.amplitude_rad);
  o.get("duration_s", opt.duration_s);
  o.get("sample_rate_hz", opt.sample_rate_hz);
  double kp = std::nan("");
  if (o.get("kp", kp)) opt.kp = kp;
  bool use_alpha = true;
  o.get("use_alpha", use_alpha);
  std::string integrator = "rk4";
  o.get("integrator", integrator);
  if (integrator == "cvode") opt.simulation.integrator = Integrator::kCvode;
  else if (integrator != "rk4") throw Error("expected \"rk4\" or \"cvode\"", {}, 0, "integrator");
  o.finish();
  SimulationOutcome out;
  out.model = model_argument(model_obj);
  std::optional<double> g1, g2;
  if (!pose.is_none()) {
    try {
      const auto p = pose.cast<std::pair<double, double>>();
      g1 = p.first, g2 = p.second;
    } catch (const py::cast_error&) {
      throw Error("expected (gamma1_deg, gamma2_deg)", {}, 0, "pose");
    }
  }
  const JointModelAtPose joint = model_at(out.model, g1, g2, use_alpha && out.model.has_alpha_model, &out.note);
  ModelRun run;
  {
    py::gil_scoped_release release;
    run = simulate_model_run(out.model, joint, opt, g1, g2);
  }
  out.ok = run.ok, out.message = run.message;
  out.data = std::make_shared<DatasetData>();
  out.data->index = model_run_dataset(out.model, run, opt.sample_rate_hz);
  out.data->runs.push_back(std::move(run.data));
  return out;
}

}  // namespace

void bind_work(py::module_& m) {
  // --- fit --------------------------------------------------------------------------------------
  py::class_<FitOutcome>(m, "FitResult", R"(What fit() found (DatasetFit): usable or not and why,
the figures (the names of `omni_fit fit --json`), the model (model.json), the reports.)")
      .def_property_readonly("usable", [](const FitOutcome& f) { return f.fit.usable(); })
      .def_property_readonly("message", [](const FitOutcome& f) { return f.fit.message; })
      .def_property_readonly("notes", [](const FitOutcome& f) { return f.fit.notes; })
      .def_property_readonly("figures", &FitOutcome::figures,
                             "runs, poses, linear/alpha errors (Tables 8 and 11), step_error_ratio")
      .def_readonly("model", &FitOutcome::model, "the fitted model (what omni_fit writes as model.json)")
      .def_property_readonly("dataset", [](const FitOutcome& f) { return f.data; })
      .def_property_readonly("brief_report", [](const FitOutcome& f) { return f.fit.brief_report(); })
      .def_property_readonly("report", [](const FitOutcome& f) { return f.fit.full_report(); },
                             "the multi-line report (DatasetFit::full_report)")
      .def_property_readonly("report_markdown", &FitOutcome::markdown,
                             "report.md as omni_fit writes it, without its figures")
      .def_property_readonly("sine_points", &FitOutcome::sine_points,
                             "the local points (19)-(20), (36) per sine run, as numpy arrays")
      .def_property_readonly("alpha_fit", &FitOutcome::alpha_fit,
                             "the alpha-model fit: ok, message, relative RMS of C and beta~ over the "
                             "points, points_used, alpha_data_min/max (where the data say anything)")
      .def_property_readonly("poses", &FitOutcome::poses, "per pose: the global linear model (22), errors")
      .def_property_readonly("kp", [](const FitOutcome& f) { return f.fit.kp; })
      .def_property_readonly("loop_period_s", [](const FitOutcome& f) { return f.fit.loop_period_s; })
      .def_property_readonly("alpha_source", [](const FitOutcome& f) { return f.fit.alpha_source; })
      .def("simulate_run", &FitOutcome::simulate_run, py::arg("run"),
           "Run `run` re-simulated with its pose's linear and alpha-model as the validation does "
           "(Figs 13-14): a dict of t, r, theta, theta_linear, theta_alpha (NaN where a model is "
           "missing) and message.")
      .def("to_dict", &FitOutcome::to_dict)
      .def("__repr__", [](const FitOutcome& f) { return "FitResult(" + f.fit.brief_report() + ")"; });
  m.def("fit", &run_fit, py::arg("dataset"),
        R"(The paper's identification of a dataset (fit_pipeline.hpp, sections 2.2-2.4): local
points (19)-(20) per sine run, the global linear model (22) per pose, the inertia model
(27)-(29), the alpha-model (38)-(42), and the validation of both (Tables 8 and 11).

dataset: a Dataset or a folder. Options (FitPipelineOptions): settle_fraction, n_breakpoints,
threads (0: all cores), run_validation, time_domain, loop_period_s, refine_breakpoints,
alpha_consistent_inertia, disturbance_passes (stage 6a, fit_stages.hpp: passes taking the
known disturbance response out of the sine points; 0: off), effects (known effects: an Effects,
spec strings or a dict),
refine_effects (refine them on all runs, effect_refinement.hpp), progress (a callable
(stage, done, total), called with the GIL from any thread). The GIL is released while it runs.
Never raises on what the data cannot support (the result says); raises alphainv.Error for an
option out of range or unknown, naming it.)");

  // --- diagnose ---------------------------------------------------------------------------------
  py::class_<DiagnoseOutcome>(m, "DiagnoseResult", R"(What diagnose() found (DiagnoseResult): the
effects named, the RMS of theta - theta_sim before and after, the rounds and candidates, where
the residual concentrates, the model with the effects folded in, the reports.)")
      .def_property_readonly("ok", [](const DiagnoseOutcome& d) { return d.result.ok; })
      .def_property_readonly("message", [](const DiagnoseOutcome& d) { return d.result.message; })
      .def_property_readonly("termination", [](const DiagnoseOutcome& d) { return termination_name(d.result.termination); })
      .def_property_readonly("effects_named", &DiagnoseOutcome::effects_named)
      .def_property_readonly("effects", [](const DiagnoseOutcome& d) { return d.result.effects; })
      .def_property_readonly("error_before", [](const DiagnoseOutcome& d) { return d.result.error_before; })
      .def_property_readonly("error_after", [](const DiagnoseOutcome& d) { return d.result.error_after; })
      .def_property_readonly("figures", &DiagnoseOutcome::figures,
                             "effect, effects, error_before, error_after, seconds, candidates")
      .def_property_readonly("rounds", &DiagnoseOutcome::rounds)
      .def_property_readonly("not_separable", &DiagnoseOutcome::not_separable,
                             "candidates the data cannot tell from the named effects: dicts of effect, "
                             "from (the named effects), share, message")
      .def_property_readonly("named", &DiagnoseOutcome::named,
                             "every named effect in order (omni_fit diagnose --json's named): dicts of "
                             "effect, error_after (RMS over all runs after its round), parameters, took_in")
      .def_property_readonly("verdict", &DiagnoseOutcome::verdict,
                             "the verdict on the final model: verdict ('explained' or "
                             "'structure_remains'), text, noise_floor, structure_rms, unexplained and not_judged "
                             "(dicts of where, size, ratio), before (the verdict on the model given)")
      .def_property_readonly("discovered", &DiagnoseOutcome::discovered,
                             "the discovered term (None: not tried): kept, equation, reading, terms, "
                             "error_before, error_after, gap_closed, carries_remainder, took_in (the named friction "
                             "whose place it took, or None), took_in_tried, took_in_error_after, took_in_structure_after, message")
      .def_property_readonly("run_levels", &DiagnoseOutcome::run_levels,
                             "the friction level fitted run by run (None: not tried): ok, varies (it differs "
                             "between runs, held out in time), report, held_out_before/after, error_before/after, "
                             "structure_before/after, gap_closed, structure_gap_closed, factor_min/max, runs "
                             "(dicts of run, factor, standard_error, rms_before, rms_after), message")
      .def_property_readonly("dropped", &DiagnoseOutcome::dropped,
                             "effects the rounds named that the model did without in the end (backward "
                             "elimination): dicts of effect, score_with, score_without, message")
      .def_property_readonly("before", [](const DiagnoseOutcome& d) { return DiagnoseOutcome::location(d.result.before); })
      .def_property_readonly("after", [](const DiagnoseOutcome& d) { return DiagnoseOutcome::location(d.result.after); })
      .def_property_readonly("model", [](const DiagnoseOutcome& d) -> py::object {
        return d.result.ok ? py::cast(d.model) : py::object(py::none());
      }, "the model with the diagnosed effects (omni_fit diagnose's model.json); None when not ok")
      .def_property_readonly("brief_report", [](const DiagnoseOutcome& d) { return d.result.brief_report(); })
      .def_property_readonly("report", [](const DiagnoseOutcome& d) { return d.result.full_report(); })
      .def_readonly("report_markdown", &DiagnoseOutcome::markdown, "report.md without its figures")
      .def("to_dict", &DiagnoseOutcome::to_dict)
      .def("__repr__", [](const DiagnoseOutcome& d) { return "DiagnoseResult(" + d.result.brief_report() + ")"; });
  m.def("diagnose", &run_diagnose, py::arg("dataset"), py::arg("model") = py::none(),
        R"(Names the effect of the catalogue that explains where a model and the data disagree
(diagnose.hpp): residual located, each candidate fitted with the alpha-model re-identified,
scored by 2-fold cross-validation in time, named only when significantly better than none.

dataset: a Dataset or a folder; model: None (fit the dataset first, as omni_fit diagnose), a
Model or a model.json path. Options (DiagnoseOptions): max_effects, threads, max_fit_runs,
max_residuals_per_run, fit_window_s, significance, candidates (effect names), reidentify,
discover (False: no discovered term after the named effects, omni_fit diagnose --no-discover),
fit_options (a dict of fit() options). GIL released while it runs. Never raises on bad data (ok,
termination, message say); raises alphainv.Error for an option out of range, naming it.)");

  // --- validate ---------------------------------------------------------------------------------
  py::class_<ValidationResult>(m, "ValidationResult", R"(A model validated on other runs
(validation.hpp): per run and pooled fit figures of theta and v (RMS, NRMSE fit %, relative
error) and the residual tests (whiteness, correlation with the input).)")
      .def_readonly("ok", &ValidationResult::ok)
      .def_readonly("message", &ValidationResult::message)
      .def_readonly("model_note", &ValidationResult::model_note)
      .def_property_readonly("figures", &validation_figures)
      .def_property_readonly("runs", [](const ValidationResult& v) {
        py::list out;
        for (const ValidatedRun& r : v.runs) out.append(run_dict(r));
        return out;
      })
      .def("theta_simulated", [](const ValidationResult& v, std::size_t i) {
        if (i >= v.runs.size()) throw Error("no run " + std::to_string(i), {}, 0, "run");
        return to_array(v.runs[i].theta_simulated);
      }, py::arg("run"), "theta_sim of run i at its samples")
      .def_property_readonly("brief_report", &ValidationResult::brief_report)
      .def_property_readonly("report", &ValidationResult::full_report)
      .def("to_dict", [](const ValidationResult& v) {
        py::dict d;
        d["ok"] = v.ok, d["message"] = v.message, d["model_note"] = v.model_note;
        d["figures"] = validation_figures(v);
        py::list runs;
        for (const ValidatedRun& r : v.runs) runs.append(run_dict(r));
        d["runs"] = runs;
        d["report"] = v.full_report();
        return d;
      })
      .def("__repr__", [](const ValidationResult& v) { return "ValidationResult(" + v.brief_report() + ")"; });
  m.def(
      "validate",
      [](py::handle model_obj, py::handle dataset, py::kwargs kwargs) {
        Options o(std::move(kwargs), "validate");
        ValidationOptions vo;
        o.get("initial_samples", vo.initial_samples);
        o.get("use_alpha", vo.use_alpha);
        o.get("threads", vo.threads);
        o.get("max_lag", vo.residual.max_lag);
        o.get("confidence", vo.residual.confidence);
        o.finish();
        vo.validate();
        const ModelFile model = model_argument(model_obj);
        const DatasetPtr d = dataset_argument(dataset);
        py::gil_scoped_release release;
        return validate_model(model, d->index, d->runs, vo);
      },
      py::arg("model"), py::arg("dataset"),
      R"(Simulates every run of the dataset with the model under the run's own controller and
reference and compares (validation.hpp; MATLAB compare/resid). Options: initial_samples,
use_alpha, threads, max_lag, confidence. GIL released while it runs.)");

  // --- simulate ---------------------------------------------------------------------------------
  py::class_<SimulationOutcome>(m, "SimulationResult", "A run simulated with a model (simulate()).")
      .def_readonly("ok", &SimulationOutcome::ok)
      .def_readonly("message", &SimulationOutcome::message)
      .def_readonly("note", &SimulationOutcome::note, "which model was used")
      .def_readonly("model", &SimulationOutcome::model)
      .def_property_readonly("run", [](const SimulationOutcome& s) { return RunView{s.data, 0}; },
                             "the run: t, r, theta (simulated), v and the columns alpha, C, beta_tilde, theta_dot")
      .def_property_readonly("dataset", [](const SimulationOutcome& s) { return s.data; },
                             "a one-run Dataset of it (write() it for omni_fit)")
      .def_property_readonly("figures", &SimulationOutcome::figures)
      .def_property_readonly("report", &SimulationOutcome::report)
      .def("to_frame", [](const SimulationOutcome& s) { return py::cast(RunView{s.data, 0}).attr("to_frame")(); })
      .def("to_dict", [](const SimulationOutcome& s) {
        py::dict d;
        d["ok"] = s.ok, d["message"] = s.message, d["note"] = s.note, d["figures"] = s.figures();
        d["report"] = s.report();
        py::dict cols;
        if (!s.data->runs.empty()) {
          RunData& r = s.data->runs[0];
          cols["t"] = r.t, cols["r"] = r.r, cols["theta"] = r.theta, cols["v"] = r.v;
          for (const auto& [name, c] : r.extra_columns) cols[py::str(name)] = c;
        }
        d["columns"] = cols;
        return d;
      })
      .def("__repr__", [](const SimulationOutcome& s) { return "SimulationResult(" + s.report() + ")"; });
  m.def("simulate", &run_simulate, py::arg("model"), py::arg("pose") = py::none(), py::arg("reference") = "sine",
        R"(One run simulated with a model (model_simulation.hpp, as omni_fit simulate): the
closed loop (43) by the fixed-point scheme (44)-(46), or the digital loop when the model was
identified with it, under the model's controller.

model: a Model, a fit/diagnosis result or a model.json path; pose: (gamma1_deg, gamma2_deg),
needed with an inertia model; reference: "sine" (from theta = 0) or "square" (from theta = -A).
Options: freq_hz (3), amplitude_rad (0.07), duration_s (8), sample_rate_hz (1000), kp,
use_alpha (True), integrator ("rk4" or "cvode"). GIL released while it runs.)");
}

}  // namespace alphainv::python
