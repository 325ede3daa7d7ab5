// The external_disturbance stage of diagnose() (DisturbanceFinding in diagnose.hpp): a torque of
// time located in every run's equation-error torque residual (external_disturbance.hpp), checked
// by simulating the runs with it as a known disturbance.
#include "alphainv/diagnose/diagnose.hpp"
#include "diagnose_stages.hpp"

#include <algorithm>
#include <cmath>

#include "alphainv/identify/time_domain_fit.hpp"
#include "alphainv/model/plant_input.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/recorded_run.hpp"
#include "common/format.hpp"
#include "common/parallel_for.hpp"

namespace alphainv::diagnose_detail {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// n̂(t_k) = (θ̈ + C·θ̇)/β̃ − u at every sample of `d` (C, β̃ from the simulation `s` of the
/// model, the run's recorded command replayed; θ̇, θ̈ of the measured θ by local quadratics over
/// ±10 ms); `valid` false in the first and last 20 ms (one-sided fits) and where n̂ is not finite.
void run_torque_residual(const RunData& d, const SimulationResult& s, const Effects& effects,
                         std::vector<double>& n_hat, std::vector<bool>& valid,
                         std::vector<double>& dth) {
  n_hat.assign(d.size(), kNaN);
  valid.assign(d.size(), false);
  std::vector<double> ddth;
  local_quadratic_derivatives(d.t, d.theta, 0.01, dth, ddth);
  if (!s.ok || s.damping.size() != d.size()) return;
  const KnownInputSeries known = KnownInputSeries::of_run(d);
  std::vector<double> memory(discovered_memory_active(effects) ? d.size() : 0);  // (no state in plant_input)
  discovered_memory_torque_along(effects, d.t.data(), dth.data(), memory.size(), memory.data());
  for (std::size_t k = 0; k < d.size(); ++k) {
    if (d.t[k] - d.t.front() < 0.02 || d.t.back() - d.t[k] < 0.02) continue;
    const double bt = s.beta_tilde[k];
    if (!(bt > 0.0)) continue;
    const double u = plant_input(effects, d.t[k], d.v[k], d.theta[k], dth[k], known.at_sample(k)) +
                     (memory.empty() ? 0.0 : memory[k]);
    n_hat[k] = (ddth[k] + s.damping[k] * dth[k]) / bt - u;
    valid[k] = std::isfinite(n_hat[k]);
  }
}

/// Samples where n̂ says more about the α-model than about a disturbance are not located: the
/// first kStartS of a run (the start from rest: on effect-free data a 2.5 Hz sine run's first
/// second held three alternating "pulses") and the kSettleS after each reference jump (a step
/// larger than 20× the median |Δr| and 1 % of r's range), where α is at the model's high end and
/// the equation error of effect-free data stands out of the spread like a pulse (a pulse there
/// is missed: docs/diagnose.md).
constexpr double kStartS = 1.0;
constexpr double kSettleS = 0.5;

/// Leaves out the start and the settling after each jump (above); returns the times where those
/// spans end.
std::vector<double> leave_out_jumps(const RunData& d, std::vector<bool>& valid) {
  std::vector<double> ends;
  if (d.size() < 3) return ends;
  std::vector<double> dr(d.size() - 1);
  for (std::size_t k = 1; k < d.size(); ++k) dr[k - 1] = std::abs(d.r[k] - d.r[k - 1]);
  std::vector<double> sorted = dr;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double dr_med = sorted[sorted.size() / 2];
  const auto [lo, hi] = std::minmax_element(d.r.begin(), d.r.end());
  double until = d.t.front() + kStartS;
  ends.push_back(until);
  for (std::size_t k = 0; k < d.size(); ++k) {
    if (k > 0 && dr[k - 1] > 20.0 * dr_med && dr[k - 1] > 0.01 * (*hi - *lo)) {
      until = d.t[k] + kSettleS;
      if (ends.back() >= d.t[k]) ends.back() = until;  // (overlapping spans: one end)
      else ends.push_back(until);
    }
    if (d.t[k] < until) valid[k] = false;
  }
  return ends;
}

/// An interval that begins within kTailWindows windows of the end of a span left out (or of an
/// interval so dropped) is that span's transient running on, not a disturbance: on effect-free
/// data a 2.5 Hz sine run near resonance still stood out at t = 1.00-1.10 and 1.15-1.30 s, just
/// after the start's second. Dropped, with its part of d̂; a pulse that begins there is missed.
constexpr double kTailWindows = 2.0;

void drop_transient_tails(const std::vector<double>& t, const std::vector<double>& span_ends,
                          double window_s, DisturbanceEstimate& est) {
  std::vector<double> ends = span_ends;
  std::vector<DisturbanceInterval> kept;
  for (const DisturbanceInterval& iv : est.intervals) {
    const bool tail = std::any_of(ends.begin(), ends.end(), [&](double e) {
      return iv.start_s >= e - 1e-9 && iv.start_s < e + kTailWindows * window_s;
    });
    if (!tail) {
      kept.push_back(iv);
      continue;
    }
    ends.push_back(iv.end_s);
    for (std::size_t k = 0; k < t.size() && k < est.d_v.size(); ++k) {
      if (t[k] >= iv.start_s && t[k] < iv.end_s) est.d_v[k] = 0.0;
    }
  }
  if (kept.size() == est.intervals.size()) return;
  est.intervals = std::move(kept);
  double ss = 0.0;
  for (double x : est.d_v) ss += x * x;
  est.rms_v = est.d_v.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(est.d_v.size()));
  if (est.intervals.empty()) {
    est.message = "what stood out began where the start or a jump's settling was left out: their "
                  "transient, not located";
  }
}

/// The functions of the state n̂ is fitted on before the location (external_disturbance.hpp):
/// friction forms (σ = tanh(θ̇/ε), ε 1 % of the run's RMS θ̇; a Stribeck hump at 10 % of it;
/// direction- and position-dependent levels), viscous and quadratic drag, a spring and its
/// square (the constant is the baseline's).
std::vector<std::vector<double>> state_basis(const std::vector<double>& theta,
                                             const std::vector<double>& dth) {
  double ss = 0.0;
  for (double x : dth) ss += x * x;
  const double rms = dth.empty() ? 0.0 : std::sqrt(ss / static_cast<double>(dth.size()));
  if (!(rms > 0.0)) return {};
  const double eps = 0.01 * rms, vs = 0.1 * rms;
  std::vector<std::vector<double>> b(8, std::vector<double>(theta.size()));
  for (std::size_t k = 0; k < theta.size(); ++k) {
    const double w = dth[k], sg = std::tanh(w / eps), x = theta[k];
    b[0][k] = sg;
    b[1][k] = sg * sg;  // with sg: a level per direction
    b[2][k] = w;
    b[3][k] = w * std::abs(w);
    b[4][k] = sg * std::exp(-(w / vs) * (w / vs));
    b[5][k] = x;
    b[6][k] = x * x;
    b[7][k] = sg * x;
  }
  return b;
}

/// The period of the run's reference r [s] when it is periodic, else 0: its upward crossings of
/// the midline (with a hysteresis of a quarter of the half-range, against noise), at least 5 of
/// them, evenly spaced to 2 % (a sine, a square wave; not a hold, a ramp or a free run).
double reference_period_s(const RunData& d) {
  if (d.r.size() < 3) return 0.0;
  const auto [lo, hi] = std::minmax_element(d.r.begin(), d.r.end());
  const double mid = 0.5 * (*lo + *hi), half = 0.5 * (*hi - *lo);
  if (!(half > 0.0) || !std::isfinite(half)) return 0.0;
  std::vector<double> ups;
  bool armed = false;  // r has been below mid − half/4 since the last crossing
  for (std::size_t k = 1; k < d.r.size(); ++k) {
    if (d.r[k] < mid - 0.25 * half) armed = true;
    if (armed && d.r[k - 1] < mid && d.r[k] >= mid) {
      const double f = (mid - d.r[k - 1]) / (d.r[k] - d.r[k - 1]);
      ups.push_back(d.t[k - 1] + f * (d.t[k] - d.t[k - 1]));
      armed = false;
    }
  }
  if (ups.size() < 5) return 0.0;
  double lo_gap = std::numeric_limits<double>::infinity(), hi_gap = 0.0;
  for (std::size_t i = 1; i < ups.size(); ++i) {
    lo_gap = std::min(lo_gap, ups[i] - ups[i - 1]);
    hi_gap = std::max(hi_gap, ups[i] - ups[i - 1]);
  }
  const double period = (ups.back() - ups.front()) / static_cast<double>(ups.size() - 1);
  return hi_gap - lo_gap <= 0.02 * period ? period : 0.0;
}

}  // namespace

std::size_t runs_touched(const DisturbanceFinding& f) {
  std::size_t n = 0;
  for (const DisturbanceEstimate& e : f.runs) n += e.intervals.empty() ? 0 : 1;
  return n;
}

bool judged_on_runs_touched(const DisturbanceFinding& f) {
  const std::size_t n = runs_touched(f);
  return n >= 2 && 2 * n >= f.runs.size();
}

JudgedDisturbanceError judged_disturbance_error(const DisturbanceFinding& f) {
  if (judged_on_runs_touched(f)) return {f.touched_before, f.touched_after, true};
  return {f.error_before, f.error_after, false};
}

bool disturbance_significant(const DisturbanceFinding& f, double significance) {
  const JudgedDisturbanceError e = judged_disturbance_error(f);
  return std::isfinite(e.after) && e.after <= (1.0 - significance) * e.before;
}

double error_over_runs(const std::vector<DiagnoseRun>& runs,
                       const std::vector<std::vector<double>>& sims, const DisturbanceFinding* touched) {
  double ss = 0.0, n = 0.0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (touched != nullptr && (i >= touched->runs.size() || touched->runs[i].intervals.empty())) continue;
    const RunData& d = *runs[i].data;
    if (sims[i].size() != d.size()) return kNaN;
    for (std::size_t k = 0; k < d.size(); ++k) ss += (d.theta[k] - sims[i][k]) * (d.theta[k] - sims[i][k]);
    n += static_cast<double>(d.size());
  }
  return n > 0 ? std::sqrt(ss / n) : kNaN;
}

DisturbanceFinding locate_external_disturbance(const std::vector<DiagnoseRun>& runs,
                                               const RoundModel& model,
                                               const DiagnoseOptions& opt) {
  DisturbanceFinding f;
  f.tried = true;
  f.run_names.resize(runs.size());
  f.runs.resize(runs.size());
  f.recorded.assign(runs.size(), false);
  DisturbanceOptions dopt;
  dopt.window_s = model.effects.disturbance_window_s > 0.0 ? model.effects.disturbance_window_s
                                                           : dopt.window_s;
  common::parallel_for(runs.size(), opt.threads, [&](std::size_t i) {
    const DiagnoseRun& run = runs[i];
    const RunData& d = *run.data;
    const InitialState x0 = initial_state_of(d, run.start, run.command_history);
    // C and β̃ at the α of the command the run recorded: the model replayed open loop (the recorded
    // v drives it; its θ is not used). The closed-loop simulation's α is the run's only while the
    // simulation tracks it: after a pulse moves the joint, near a resonance, it departs for cycles
    // and n̂ carries (C_sim − C)·θ̇ (the 2 Hz run of cogging + pulses, seed 41: window means 4×
    // wider than with the recorded command's α, and none of its five pulses located).
    // (The closed-loop one when the replay fails.)
    const JointModelAtPose m = diagnosed_model(run.model, model.effects, model.scales, model.alpha);
    Controller replay = run.controller;
    replay.kp = replay.ki = replay.kd = 0.0;  // is_open_loop()
    SimulationResult s = simulate_recorded_run(m, replay, d, x0, opt.simulation);
    if (!s.ok) s = simulate_recorded_run(m, run.controller, d, x0, opt.simulation);
    std::vector<double> n_hat, dth;
    std::vector<bool> valid;
    run_torque_residual(d, s, model.effects, n_hat, valid, dth);
    const std::vector<double> span_ends = leave_out_jumps(d, valid);
    DisturbanceOptions run_opt = dopt;
    run_opt.reference_period_s = reference_period_s(d);
    f.runs[i] = locate_disturbance(d.t, n_hat, valid, run_opt, state_basis(d.theta, dth), d.theta);
    drop_transient_tails(d.t, span_ends, dopt.window_s, f.runs[i]);
  });
  double ss = 0.0, n = 0.0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    f.run_names[i] = runs[i].name;
    f.recorded[i] = runs[i].data->column("disturbance_v") != nullptr;
    if (f.runs[i].intervals.empty()) continue;
    f.intervals += f.runs[i].intervals.size();
    for (double x : f.runs[i].d_v) ss += x * x;
    n += static_cast<double>(f.runs[i].d_v.size());
  }
  f.rms_v = n > 0 ? std::sqrt(ss / n) : 0.0;
  std::size_t mirrored = 0, mirrored_runs = 0;
  for (const DisturbanceEstimate& e : f.runs) {
    mirrored += e.half_period_pairs_set_aside;
    mirrored_runs += e.half_period_pairs_set_aside > 0 ? 1 : 0;
  }
  if (f.intervals == 0) {
    f.message = mirrored == 0
                    ? "no time window of the torque residual stands out of its spread in any run"
                    : std::to_string(mirrored) + " time window(s) of the torque residual in " +
                          std::to_string(mirrored_runs) +
                          " run(s) stand out, each with one of the opposite sign half a reference "
                          "period away: the model's misfit along the reference, not a torque of time";
    return f;
  }
  // Checked by simulation: every run with d̂ added to its disturbance_v column.
  f.named = true;  // (for with_located_disturbance; decided below)
  std::vector<RunData> with_d;
  const std::vector<DiagnoseRun> runs_d = with_located_disturbance(runs, f, with_d);
  const auto sims_before =
      simulate_diagnosed(runs, model.effects, model.scales, opt.simulation, opt.threads, model.alpha);
  const auto sims_after =
      simulate_diagnosed(runs_d, model.effects, model.scales, opt.simulation, opt.threads, model.alpha);
  f.error_before = error_over_runs(runs, sims_before);
  f.error_after = error_over_runs(runs_d, sims_after);
  f.touched_before = error_over_runs(runs, sims_before, &f);
  f.touched_after = error_over_runs(runs_d, sims_after, &f);
  const std::size_t touched = runs_touched(f);
  const std::string sizes = std::to_string(f.intervals) + " interval(s) in " + std::to_string(touched) +
                            " run(s), d RMS " + common::format("%.3g", f.rms_v) +
                            "; RMS of theta - theta_sim over those runs " +
                            common::format("%.4g", f.touched_before) + " -> " +
                            common::format("%.4g", f.touched_after) + " with it known (all runs " +
                            common::format("%.4g", f.error_before) + " -> " +
                            common::format("%.4g", f.error_after) + ")";
  f.named = disturbance_significant(f, opt.significance);
  f.message = f.named ? "located in time: " + sizes
                      : "located in time but not below (1 - significance) x the error before: " + sizes;
  return f;
}

}  // namespace alphainv::diagnose_detail

namespace alphainv {

std::vector<DiagnoseRun> with_located_disturbance(const std::vector<DiagnoseRun>& runs,
                                                  const DisturbanceFinding& f,
                                                  std::vector<RunData>& storage) {
  storage.clear();
  if (!f.named || f.runs.size() != runs.size()) return runs;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    if (!f.runs[i].intervals.empty() && f.runs[i].d_v.size() != runs[i].data->size()) return runs;
  }
  storage.reserve(runs.size());
  std::vector<DiagnoseRun> out = runs;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    storage.push_back(*runs[i].data);
    if (f.runs[i].intervals.empty()) continue;
    RunData& d = storage.back();
    std::vector<double>& col = d.extra_columns["disturbance_v"];
    col.resize(d.size(), 0.0);
    for (std::size_t k = 0; k < d.size(); ++k) col[k] += f.runs[i].d_v[k];
  }
  for (std::size_t i = 0; i < runs.size(); ++i) out[i].data = &storage[i];
  return out;
}

}  // namespace alphainv
