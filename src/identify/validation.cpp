#include "alphainv/identify/validation.hpp"

#include <nlopt.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "alphainv/error.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/model_simulation.hpp"
#include "alphainv/simulate/recorded_run.hpp"
#include "alphainv/simulate/reference.hpp"
#include "common/format.hpp"
#include "common/parallel_for.hpp"

namespace alphainv {

namespace {


/// Σ (θ − θ_sim)² over the first n samples from x0 = (θ0, θ̇0).
struct InitialFit {
  const JointModelAtPose* joint;
  const Controller* controller;
  const Reference* reference;
  const RunData* data;
  std::vector<double> times;
  SimulationOptions simulation;
  InitialState base;
  KnownInputSeries known;
};

double initial_objective(unsigned, const double* x, double*, void* p) {
  const auto& f = *static_cast<const InitialFit*>(p);
  InitialState x0 = f.base;
  x0.theta = x[0];
  x0.theta_dot = x[1];
  // Open loop: the reference is the recorded command (simulate_recorded_run).
  const SimulationResult s =
      is_open_loop(*f.controller)
          ? simulate_open_loop(*f.joint, *f.reference, f.times, x0, f.simulation, f.known)
          : simulate(*f.joint, *f.controller, *f.reference, f.times, x0, f.simulation, f.known);
  if (!s.ok || s.theta.size() != f.times.size()) return 1e30;
  double ss = 0.0;
  for (std::size_t k = 0; k < f.times.size(); ++k) {
    const double e = f.data->theta[k] - s.theta[k];
    ss += e * e;
  }
  return std::isfinite(ss) ? ss : 1e30;
}

/// θ0, θ̇0 fitted to the first n samples (Nelder-Mead from the measured state).
InitialState fit_initial_state(InitialFit& f, std::size_t n) {
  f.times.assign(f.data->t.begin(), f.data->t.begin() + static_cast<std::ptrdiff_t>(n));
  double lo = f.data->theta[0], hi = lo;
  for (std::size_t k = 0; k < n; ++k) {
    lo = std::min(lo, f.data->theta[k]);
    hi = std::max(hi, f.data->theta[k]);
  }
  const double span_s = std::max(f.times.back() - f.times.front(), 1e-3);
  std::vector<double> x{f.base.theta, f.base.theta_dot};
  const double step_theta = std::max(0.1 * (hi - lo), 1e-6);
  std::vector<double> step{step_theta, std::max(step_theta / span_s, 1e-6)};
  nlopt_opt opt = nlopt_create(NLOPT_LN_NELDERMEAD, 2);
  nlopt_set_initial_step(opt, step.data());
  nlopt_set_min_objective(opt, initial_objective, &f);
  nlopt_set_ftol_rel(opt, 1e-10);
  nlopt_set_maxeval(opt, 200);
  double cost = 0.0;
  const nlopt_result r = nlopt_optimize(opt, x.data(), &cost);
  nlopt_destroy(opt);
  InitialState out = f.base;
  if (r > 0 && cost < 1e29) {
    out.theta = x[0];
    out.theta_dot = x[1];
  }
  return out;
}

/// The median sample step of `t` [s] (0 for fewer than 2 samples).
double median_period(const std::vector<double>& t) {
  if (t.size() < 2) return 0.0;
  std::vector<double> dt(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) dt[k - 1] = t[k] - t[k - 1];
  return median(std::move(dt));
}

ValidatedRun validate_run(const ModelFile& model, const RunInfo& info, const RunData& d,
                           const ValidationOptions& options, std::string* note) {
  ValidatedRun v;
  v.file = info.file;
  if (d.size() < 2) {
    v.message = "fewer than 2 samples";
    return v;
  }
  JointModelAtPose joint;
  try {
    joint = model_at(model, info.gamma1_deg, info.gamma2_deg, options.use_alpha, note);
  } catch (const Error& e) {
    v.message = e.what();
    return v;
  }
  // The run's controller; a dataset that states none runs under the model's.
  const Controller controller = info.controller.kp > 0.0 ? info.controller : model.controller;
  const SampledReference reference(d.t, is_open_loop(controller) ? d.v : d.r);
  SimulationOptions so = options.simulation;
  so.loop_period_s = model.loop_period_s;
  InitialState x0 = initial_state_of(d);
  const KnownInputUse use = options.use_known_inputs ? KnownInputUse::kUse : KnownInputUse::kIgnore;
  if (options.initial_samples > 0) {
    if (options.initial_samples + 2 > d.size()) {
      v.message = "has " + std::to_string(d.size()) + " samples, not more than --initial-samples " +
                  std::to_string(options.initial_samples);
      return v;
    }
    InitialFit f{&joint, &controller, &reference, &d, {}, so, x0, {}};
    if (use == KnownInputUse::kUse) f.known = KnownInputSeries::of_run(d);
    x0 = fit_initial_state(f, options.initial_samples);
    v.first_sample = options.initial_samples;
  }
  const SimulationResult s = simulate_recorded_run(joint, controller, d, x0, so, use);
  if (!s.ok || s.theta.size() != d.size()) {
    v.message = "simulation failed: " + s.message;
    return v;
  }
  v.ok = true;
  v.theta_simulated = s.theta;
  v.position = fit_figures(d.theta, s.theta, v.first_sample);
  v.command = fit_figures(d.v, s.v, v.first_sample);
  std::vector<double> e(d.theta.begin() + static_cast<std::ptrdiff_t>(v.first_sample), d.theta.end());
  for (std::size_t k = 0; k < e.size(); ++k) e[k] -= s.theta[k + v.first_sample];
  // The input of the residual tests: r in closed loop, the recorded command v in open loop.
  const std::vector<double>& input = is_open_loop(controller) ? d.v : d.r;
  const std::vector<double> u(input.begin() + static_cast<std::ptrdiff_t>(v.first_sample),
                              input.end());
  ResidualTestOptions ro = options.residual;
  if (ro.sample_period_s <= 0.0) ro.sample_period_s = median_period(d.t);
  v.residual = residual_tests(e, u, ro);
  return v;
}

}  // namespace

void ValidationOptions::validate() const {
  if (residual.max_lag == 0) throw Error("expected a number of lags > 0", {}, 0, "residual.max_lag");
  if (!(residual.confidence > 0.0 && residual.confidence < 1.0)) {
    throw Error("expected a confidence in (0, 1), got " + common::num(residual.confidence), {}, 0,
                "residual.confidence");
  }
}

ValidationResult validate_model(const ModelFile& model, const Dataset& dataset,
                                const std::vector<RunData>& data, const ValidationOptions& options) {
  options.validate();
  const auto t0 = std::chrono::steady_clock::now();
  ValidationResult res;
  if (data.size() != dataset.runs.size()) {
    res.message = "the dataset names " + std::to_string(dataset.runs.size()) + " runs, " +
                  std::to_string(data.size()) + " were read";
    return res;
  }
  res.runs.resize(data.size());
  std::vector<std::string> notes(data.size());
  common::parallel_for(data.size(), options.threads, [&](std::size_t i) {
    res.runs[i] = validate_run(model, dataset.runs[i], data[i], options, &notes[i]);
  });
  std::vector<FitFigures> pos, cmd;
  for (std::size_t i = 0; i < res.runs.size(); ++i) {
    const ValidatedRun& r = res.runs[i];
    if (!r.ok) continue;
    if (res.model_note.empty()) res.model_note = "first run (" + r.file + "): " + notes[i];
    pos.push_back(r.position);
    cmd.push_back(r.command);
    if (r.residual.valid) {
      ++res.runs_tested;
      res.runs_white += r.residual.white;
      res.runs_input_correlated += r.residual.input_correlated;
    }
  }
  res.position = pooled_fit_figures(pos);
  res.command = pooled_fit_figures(cmd);
  res.ok = !pos.empty();
  if (!res.ok) {
    res.message = res.runs.empty() ? "no runs" : "no run could be simulated; the first: " +
                                                     res.runs.front().file + ": " +
                                                     res.runs.front().message;
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

std::string ValidationResult::brief_report() const {
  if (!ok) return "validation failed: " + message;
  std::size_t validated = 0;
  for (const ValidatedRun& r : runs) validated += r.ok;
  return common::format("validated %zu/%zu runs: theta RMS %.4g, max %.4g, fit %.1f %%, relative "
                        "error %.4g; residual white in %zu/%zu runs, input-correlated in %zu/%zu",
                        validated, runs.size(), position.rms, position.max_abs, position.fit_percent,
                        position.relative_error, runs_white, runs_tested, runs_input_correlated,
                        runs_tested);
}

std::string ValidationResult::full_report() const {
  std::string out = brief_report() + "\n";
  if (!model_note.empty()) out += "model: " + model_note + "\n";
  for (const ValidatedRun& r : runs) {
    if (!r.ok) {
      out += "  " + r.file + ": not validated: " + r.message + "\n";
      continue;
    }
    out += common::format("  %s: RMS %.4g, max %.4g, fit %.1f %%, rel %.4g; ", r.file.c_str(),
                          r.position.rms, r.position.max_abs, r.position.fit_percent,
                          r.position.relative_error) +
           r.residual.verdict() + "\n";
  }
  return out;
}

}  // namespace alphainv
