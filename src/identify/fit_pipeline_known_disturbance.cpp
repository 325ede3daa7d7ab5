// fit_dataset(), stage 6a (fit_stages.hpp): the response to a known disturbance taken out of the
// sine runs' local points.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "alphainv/identify/fit_stages.hpp"
#include "alphainv/simulate/recorded_run.hpp"
#include "common/parallel_for.hpp"
#include "fit_pipeline_internal.hpp"

namespace alphainv {

namespace {

constexpr double kPointTolerance = 1e-3;  // stop when no point moves by 0.1 % or more

/// The run has a `disturbance_v` column with a value other than 0.
bool has_nonzero_disturbance(const RunData& run) {
  const std::vector<double>* d = run.column("disturbance_v");
  return d != nullptr && std::any_of(d->begin(), d->end(), [](double x) { return x != 0.0; });
}

/// Largest relative change of C_data or β_data between the physical points of the same runs in
/// `before` and `after`; +inf when the runs or their physical flags differ.
double point_change(const DatasetFit& before, const DatasetFit& after) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (before.sine_points.size() != after.sine_points.size()) return kInf;
  double change = 0.0;
  for (std::size_t k = 0; k < before.sine_points.size(); ++k) {
    const SineRunPoint& a = before.sine_points[k];
    const SineRunPoint& b = after.sine_points[k];
    if (a.run != b.run || a.point.physical != b.point.physical) return kInf;
    if (!a.point.physical) continue;
    change = std::max({change, std::abs(b.point.c_data / a.point.c_data - 1.0),
                       std::abs(b.point.beta_data / a.point.beta_data - 1.0)});
  }
  return change;
}

/// One disturbed run under one pass's model: the simulation with its disturbance_v column
/// against the measured θ, and (when `out` is given) the run with the model's response to the
/// column taken out (file comment of fit_stages.hpp, stage 6a).
struct RunCorrection {
  bool ok = false;           ///< the simulations ran (and `out` was written)
  double squared_error = 0;  ///< Σ (θ_sim − θ)² of the simulation with the column [rad²]
};

RunCorrection correct_run(const JointModelAtPose& model, const Controller& controller,
                          const RunData& run, const SimulationOptions& simulation, RunData* out) {
  RunCorrection c;
  if (!(model.c_linear > 0.0) || !(model.beta_tilde_linear > 0.0)) return c;
  const InitialState x0 = initial_state_of(run);
  const SimulationResult with = simulate_recorded_run(model, controller, run, x0, simulation);
  if (!with.ok || with.theta.size() != run.size() || with.v.size() != run.size()) return c;
  for (std::size_t k = 0; k < run.size(); ++k) {
    c.squared_error += (with.theta[k] - run.theta[k]) * (with.theta[k] - run.theta[k]);
  }
  if (out != nullptr) {
    RunData calm = run;
    calm.extra_columns.erase("disturbance_v");
    const SimulationResult without = simulate_recorded_run(model, controller, calm, x0, simulation);
    if (!without.ok || without.theta.size() != run.size() || without.v.size() != run.size()) {
      return c;
    }
    for (std::size_t k = 0; k < run.size(); ++k) {
      calm.theta[k] -= with.theta[k] - without.theta[k];
      calm.v[k] -= with.v[k] - without.v[k];
    }
    *out = std::move(calm);
  }
  c.ok = true;
  return c;
}

std::string percent_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g %%", 100.0 * x);
  return b;
}

std::string number_text(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g", x);
  return b;
}

}  // namespace

void remove_known_disturbance_response(const Dataset& dataset, const std::vector<RunData>& data,
                                       const FitPipelineOptions& options, DatasetFit& fit) {
  std::vector<SineRunPoint> disturbed;  // the sine runs with a nonzero disturbance_v
  for (const SineRunPoint& sp : fit.sine_points) {
    if (has_nonzero_disturbance(data[sp.run])) disturbed.push_back(sp);
  }
  if (disturbed.empty()) return;
  fit.disturbance_correction.runs_with_disturbance = disturbed.size();
  if (options.disturbance_passes <= 0) {
    fit.notes.push_back(
        "known disturbance response left in the sine points (disturbance passes 0): " +
        std::to_string(disturbed.size()) +
        " sine run(s) have a nonzero disturbance_v; their points read θ against the plant input "
        "with d(t) in it (effect_sine_point.hpp), where a pulse transient in the steady-state "
        "window still biases them");
    return;
  }
  if (!fit.usable()) return;
  detail::ProgressReporter progress(options);
  const auto passes = static_cast<std::size_t>(options.disturbance_passes);
  KnownDisturbanceCorrection done;
  done.runs_with_disturbance = disturbed.size();
  std::vector<RunData> corrected = data;
  // The disturbed runs simulated with `model`'s models (their columns in): the RMS error on the
  // measured θ [rad], and with `correct` their corrected copies in `corrected` (the measured run
  // where a simulation fails); `ok_runs` the runs whose simulations ran.
  auto simulate_pass = [&](const DatasetFit& model, bool correct, std::size_t& ok_runs) {
    std::vector<RunCorrection> c(disturbed.size());
    common::parallel_for(disturbed.size(), options.threads, [&](std::size_t k) {
      const std::size_t i = disturbed[k].run;
      c[k] = correct_run(model.model_for_pose(disturbed[k].pose), dataset.runs[i].controller,
                         data[i], model.simulation, correct ? &corrected[i] : nullptr);
      if (correct && !c[k].ok) corrected[i] = data[i];  // its point reads d(t) in the input
    });
    double sum = 0.0;
    std::size_t samples = 0;
    ok_runs = 0;
    for (std::size_t k = 0; k < c.size(); ++k) {
      if (!c[k].ok) continue;
      ++ok_runs;
      sum += c[k].squared_error;
      samples += data[disturbed[k].run].size();
    }
    return samples > 0 ? std::sqrt(sum / static_cast<double>(samples))
                       : std::numeric_limits<double>::quiet_NaN();
  };
  // Each pass's model is judged by how well it predicts the measured disturbed runs (the first
  // simulation of the next pass); the best of the first pass and the refits is kept. (The
  // α-model's breakpoint search can make the refits cycle between neighbouring models instead of
  // settling.)
  DatasetFit current = fit;
  DatasetFit best = fit;
  std::size_t best_pass = 0;
  double best_rms = std::numeric_limits<double>::infinity();
  for (std::size_t pass = 0; pass <= passes; ++pass) {
    progress("known disturbance response", pass, passes + 1);
    std::size_t ok_runs = 0;
    const bool refit = pass < passes && !(done.last_point_change < kPointTolerance);
    const double rms = simulate_pass(current, refit, ok_runs);
    if (pass == 0) done.first_pass_rms_rad = rms;
    if (pass > 0 && rms < best_rms) {
      best = current;
      best_pass = pass;
    }
    if ((pass == 0 && std::isfinite(rms)) || rms < best_rms) best_rms = rms;
    if (!refit || ok_runs == 0) break;
    done.runs_corrected = ok_runs;
    DatasetFit next = fit_sine_stages(dataset, corrected, options);
    if (!next.usable()) break;
    done.last_point_change = point_change(current, next);
    done.passes = static_cast<int>(pass) + 1;
    current = std::move(next);
  }
  progress("known disturbance response", passes + 1, passes + 1);
  done.chosen_pass = static_cast<int>(best_pass);
  done.chosen_rms_rad = std::isfinite(best_rms) ? best_rms : done.first_pass_rms_rad;
  if (done.passes == 0) {
    fit.disturbance_correction = done;
    fit.notes.push_back(
        "known disturbance response not taken out of the sine points: " +
        std::to_string(done.runs_with_disturbance) +
        " sine run(s) have a nonzero disturbance_v, but the first-pass model's simulations "
        "failed or the refit gave no model; their points read θ against the plant input with "
        "d(t) in it (effect_sine_point.hpp)");
    return;
  }
  fit = std::move(best);
  fit.disturbance_correction = done;
  fit.notes.push_back(
      "known disturbance response taken out of the sine points: " +
      std::to_string(done.runs_corrected) + " of " + std::to_string(done.runs_with_disturbance) +
      " sine run(s) with a nonzero disturbance_v corrected (the model's response to d(t), "
      "simulated with and without the column, subtracted from θ and v), " +
      std::to_string(done.passes) + " pass(es) of stages 1-6, last point change " +
      percent_text(done.last_point_change) +
      (done.last_point_change < kPointTolerance ? " (< 0.1 %: settled)" : " (not settled)") +
      "; kept: " +
      (best_pass == 0 ? std::string("the first pass (no refit predicted the disturbed runs better)")
                      : "pass " + std::to_string(best_pass)) +
      ", RMS error on the disturbed runs " + number_text(done.first_pass_rms_rad) + " → " +
      number_text(done.chosen_rms_rad) + " rad");
}

}  // namespace alphainv
