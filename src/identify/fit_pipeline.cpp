#include "alphainv/identify/fit_pipeline.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <mutex>

#include "alphainv/identify/effect_sine_point.hpp"
#include "alphainv/identify/fit_stages.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/model/detail/field_checks.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "alphainv/simulate/reference.hpp"
#include "common/parallel_for.hpp"
#include "fit_pipeline_internal.hpp"

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double wrap_rad(double a) { return std::remainder(a, 2.0 * kPi); }

/// p-th percentile over the finite values; NaN when there are none.
double finite_percentile(const std::vector<double>& v, double p) {
  std::vector<double> f;
  for (double x : v) {
    if (std::isfinite(x)) f.push_back(x);
  }
  return f.empty() ? kNaN : percentile(std::move(f), p);
}
double finite_median(const std::vector<double>& v) { return finite_percentile(v, 50.0); }
double finite_p90(const std::vector<double>& v) { return finite_percentile(v, 90.0); }

std::string format_g(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", x);
  return b;
}

bool is_periodic_kind(const RunInfo& run) {
  return (run.kind == "sine") && run.freq_hz && *run.freq_hz > 0.0;
}

bool is_step_kind(const RunInfo& run) { return run.kind == "square" || run.kind == "step"; }

/// Why a sine run's declared freq_hz is not what its reference holds, or empty (issue #13): the
/// sine (15) fitted to r at that frequency (`fr`, on the steady-state window) must explain at
/// least half of r's variance there (a sine at its own frequency: all of it; at 10 times it: ~0).
/// The note gives the frequency at which r crosses its mean over the run, the data's own.
std::string declared_frequency_mismatch(const RunInfo& run, const RunData& d, const SineFit& fr) {
  const double fitted = 0.5 * fr.amplitude() * fr.amplitude();
  const double explained = fitted / (fitted + fr.rms_residual * fr.rms_residual);
  if (explained >= 0.5) return {};
  // Half periods between the first and the last crossing, over the whole run (the window may hold
  // few of r's periods).
  std::size_t crossings = 0;
  double first_s = 0.0, last_s = 0.0;
  for (std::size_t k = 1; k < d.size(); ++k) {
    if ((d.r[k - 1] - fr.offset < 0.0) == (d.r[k] - fr.offset < 0.0)) continue;
    if (crossings++ == 0) first_s = d.t[k];
    last_s = d.t[k];
  }
  const double span_s = crossings > 1 ? (last_s - first_s) * static_cast<double>(crossings) /
                                            static_cast<double>(crossings - 1)
                                      : 0.0;
  char measured[128];
  std::snprintf(measured, sizeof measured, "explains %.3g %% of r's variance; r crosses its mean "
                "at about %.3g Hz", 100.0 * explained,
                span_s > 0.0 ? 0.5 * static_cast<double>(crossings) / span_s : kNaN);
  return "run " + run.file + ": declared freq_hz " + format_g(*run.freq_hz) +
         " is not the reference's frequency (a sine at it " + measured +
         "): skipped; correct freq_hz in dataset.json";
}

/// (27)-(29) identify I from β̃_linear = 1/I, but the α-model (42) says β̃ = 1/(β̃_n1(α)·I): when the
/// α on each pose's resonance band differs between poses, 1/β̃_linear is not proportional to the
/// inertia, and every α-model coefficient inherits a pose-dependent scale error (±6 % on generated
/// data; C_linear at the band α carries the same bias). So: take each pose's inertia that best fits
/// the α-model to its points (alpha_model_pose_inertia), scaled so that their sum equals the first
/// fit's, fit (27)-(28) to it (C_linear passed as 1/(C̄0·I_pose), consistent, so only the shape is
/// learnt), take C̄0 from the band's C_linear by the paper's regression β̃ = C̄0·C with β̃ = 1/I, and
/// refit the α-model with the new I; repeat until the inertias settle.
void refit_inertia_with_alpha_model(DatasetFit& fit, std::vector<AlphaFitPose>& apose,
                                    const std::vector<std::size_t>& pose_of,
                                    const AlphaFitOptions& aopt) {
  const double c0_first = fit.inertia.model.c0_bar;
  int iterations = 0;
  double change = 0.0;
  for (; iterations < 4; ++iterations) {
    const std::vector<double> ieff = alpha_model_pose_inertia(apose, fit.alpha.model, aopt.kp);
    double sum_old = 0.0, sum_new = 0.0;
    for (std::size_t k = 0; k < apose.size(); ++k) {
      if (std::isfinite(ieff[k])) {
        sum_old += apose[k].inertia;
        sum_new += ieff[k];
      }
    }
    std::vector<InertiaPose> ip;
    for (std::size_t k = 0; k < apose.size(); ++k) {
      const PoseFit& pose = fit.poses[pose_of[k]];
      if (!std::isfinite(ieff[k]) || !pose.linear.valid || !pose.gamma1_deg) continue;
      const double inertia = ieff[k] * sum_old / sum_new;
      ip.push_back({deg_to_rad(*pose.gamma1_deg), deg_to_rad(*pose.gamma2_deg),
                    1.0 / (c0_first * inertia), 1.0 / inertia});
    }
    if (ip.size() < 6) break;
    const InertiaFitOptions iopt{};
    InertiaFitSummary s = fit_inertia_model(ip, iopt);
    if (!s.converged) break;
    // Each pose's information is in it twice (C passed consistent with β̃): the Ceres SEs assume
    // 2n independent residuals and n_res − 6 degrees of freedom; really n poses, n − 5 for the
    // shape.
    const double n_poses = static_cast<double>(ip.size());
    const double se_scale =
        n_poses > 5.0 ? std::sqrt((2.0 * n_poses - 6.0) / (n_poses - 5.0)) : kNaN;
    for (int k = 0; k < kC0Bar; ++k) {
      const auto i = static_cast<std::size_t>(k);
      s.standard_errors[i] *= se_scale;
      const bool se_bad = k == kGammaOffs
                              ? !(s.standard_errors[i] <= iopt.poorly_determined_gamma_offs_se_rad)
                              : !(s.standard_errors[i] <=
                                  iopt.poorly_determined_relative_se * std::abs(s.parameters[i]));
      s.poorly_determined[i] = s.poorly_determined[i] || se_bad;
    }
    s.covariance *= se_scale * se_scale;
    // C̄0 from the band's C_linear (eq. (29) with the new I), through the origin, with its SE.
    double sxx = 0.0, sxy = 0.0, ss = 0.0, sc = 0.0, sb = 0.0;
    std::size_t n = 0;
    for (const PoseFit& pose : fit.poses) {
      if (!pose.linear.valid || !pose.gamma1_deg) continue;
      const double i =
          s.model.inertia.inertia(deg_to_rad(*pose.gamma1_deg), deg_to_rad(*pose.gamma2_deg));
      sxx += pose.linear.c_linear * pose.linear.c_linear;
      sxy += pose.linear.c_linear / i;
      ++n;
    }
    const double c0 = sxy / sxx;
    for (const PoseFit& pose : fit.poses) {
      if (!pose.linear.valid || !pose.gamma1_deg) continue;
      const double i =
          s.model.inertia.inertia(deg_to_rad(*pose.gamma1_deg), deg_to_rad(*pose.gamma2_deg));
      ss += std::pow(1.0 / i - c0 * pose.linear.c_linear, 2);
      sc += std::pow(1.0 / (c0 * i * pose.linear.c_linear) - 1.0, 2);
      sb += std::pow(1.0 / (i * pose.linear.beta_tilde_linear) - 1.0, 2);
    }
    s.model.c0_bar = c0;
    s.parameters[kC0Bar] = c0;
    s.standard_errors[kC0Bar] = n > 1 ? std::sqrt(ss / static_cast<double>(n - 1) / sxx) : kNaN;
    s.poorly_determined[kC0Bar] = !(s.standard_errors[kC0Bar] <= 0.5 * c0);
    // The report's "RMS relative error of the model" stays against the band's linear fits.
    s.rms_relative_c = std::sqrt(sc / static_cast<double>(n));
    s.rms_relative_beta_tilde = std::sqrt(sb / static_cast<double>(n));
    change = 0.0;
    std::vector<AlphaFitPose> next = apose;
    for (std::size_t k = 0; k < apose.size(); ++k) {
      const PoseFit& pose = fit.poses[pose_of[k]];
      if (!pose.gamma1_deg) continue;
      next[k].inertia =
          s.model.inertia.inertia(deg_to_rad(*pose.gamma1_deg), deg_to_rad(*pose.gamma2_deg));
      change = std::max(change, std::abs(next[k].inertia / apose[k].inertia - 1.0));
    }
    AlphaFitResult a = fit_alpha_model(next, aopt);
    if (!a.ok) break;
    apose = std::move(next);
    fit.inertia = std::move(s);
    fit.alpha = std::move(a);
    for (PoseFit& pose : fit.poses) {
      if (pose.gamma1_deg) {
        pose.inertia = fit.inertia.model.inertia.inertia(deg_to_rad(*pose.gamma1_deg),
                                                         deg_to_rad(*pose.gamma2_deg));
      }
    }
    if (change < 1e-4) break;
  }
  fit.notes.push_back(
      "inertia model re-identified consistently with the α-model (" +
      std::to_string(iterations + 1) + " pass(es), last change of I " + format_g(100 * change) +
      " %): (27)-(28) fitted to the per-pose inertia that best fits the α-model to the pose's "
      "points (scaled to the first fit's mean), C̄0 regressed on the band's C_linear with that I. "
      "Reason: β̃_linear = 1/I holds only at one α, and the band's α differs between poses");
}

/// Notes on what the data pin down: the inertia model's poorly determined parameters (its SEs and
/// correlations), the α-model's breakpoints and coefficients against the data's α range and SEs.
void identifiability_notes(DatasetFit& fit) {
  if (fit.has_inertia_model) {
    std::string bad;
    for (int k = 0; k < kInertiaFitParameterCount; ++k) {
      const auto i = static_cast<std::size_t>(k);
      if (fit.inertia.poorly_determined[i]) {
        bad += std::string(bad.empty() ? "" : ", ") + inertia_fit_parameter_name(k) + " (SE " +
               format_g(fit.inertia.standard_errors[i]) + " on " +
               format_g(fit.inertia.parameters[i]) + ")";
      }
    }
    fit.notes.push_back(
        "identifiability, inertia model: " +
        (bad.empty() ? std::string("every parameter has a relative SE below the threshold and no "
                                   "correlation above 0.99")
                     : "poorly determined: " + bad) +
        ". The overall scale of I is not identifiable from any data (C = 1/(C_n1·I) and "
        "β̃ = 1/(β̃_n1·I) are unchanged by I → kI, C_n1 → C_n1/k, β̃_n1 → β̃_n1/k); it is fixed by "
        "β̃_linear = 1/I (eq. 25) on average over the poses");
  }
  if (fit.alpha.ok) {
    const AlphaFitResult& a = fit.alpha;
    const AlphaModel& m = a.model;
    std::string pinned, free_bp, c_bad;
    for (std::size_t k = 1; k < m.n_breakpoints; ++k) {
      (a.breakpoint_identifiable[k] ? pinned : free_bp) +=
          std::string((a.breakpoint_identifiable[k] ? pinned : free_bp).empty() ? "" : ", ") + "α" +
          std::to_string(k) + " = " + format_g(m.alpha[k]);
    }
    for (std::size_t k = 0; k < m.n_breakpoints; ++k) {
      if (!a.c_n1_identifiable[k]) {
        c_bad += std::string(c_bad.empty() ? "" : ", ") + "C_" + std::to_string(k) + "1 (SE " +
                 format_g(a.c_n1_se[k]) + " on " + format_g(m.c_n1[k]) + ")";
      }
    }
    for (std::size_t k = 0; k < 2; ++k) {
      if (!a.beta_n1_identifiable[k]) {
        c_bad += std::string(c_bad.empty() ? "" : ", ") + "β̃_" + std::to_string(k) +
                 "1 at ᾱ = " + format_g(m.beta_alpha[k]) + " (SE " + format_g(a.beta_n1_se[k]) +
                 ")";
      }
    }
    fit.notes.push_back(
        "identifiability, α-model: the data cover α = " + format_g(a.alpha_data_min) + " … " +
        format_g(a.alpha_data_max) +
        "; breakpoints with data on both sides (pinned): " + (pinned.empty() ? "none" : pinned) +
        "; not pinned by the data: " + (free_bp.empty() ? "none" : free_bp) +
        (c_bad.empty()
             ? "; every C_n1, β̃_n1 is measured within the data with relative SE ≤ 10 %"
             : "; coefficients not identifiable (extrapolated beyond the data, tied to an unpinned "
               "top breakpoint, or relative SE > 10 %): " +
                   c_bad) +
        ". Trust C(α, I), β̃(α, I) inside the α range, not single coefficients outside it");
    fit.notes.push_back("α-model breakpoints: exhaustive grid search over " +
                        std::to_string(a.candidates_tried) + " sets, then " +
                        (a.refine_evaluations > 0
                             ? "NLopt Nelder-Mead on ln α from the grid winner (" +
                                   std::to_string(a.refine_evaluations) + " evaluations; score " +
                                   format_g(a.grid_score) + " → " + format_g(a.score) + ")"
                             : std::string("no refinement")));
  }
}


/// Stage 2's set-up: the digital-loop period T of the correction of (19)-(20) (from the options,
/// else from the dataset's sample rate) and the known effects, each with its note.
void set_loop_period_and_effects(const Dataset& dataset, const FitPipelineOptions& options,
                                 DatasetFit& fit) {
  if (std::isnan(options.loop_period_s)) {
    fit.loop_period_s = dataset.sample_rate_hz && *dataset.sample_rate_hz > 0.0
                            ? 1.0 / *dataset.sample_rate_hz
                            : 0.0;
  } else {
    fit.loop_period_s = std::max(0.0, options.loop_period_s);
  }
  fit.notes.push_back(
      fit.loop_period_s > 0.0
          ? "digital-loop correction: the sine runs are taken as a P law ticking every T = " +
                format_g(fit.loop_period_s * 1e3) +
                " ms with the command held over the tick (zero-order hold); C_data and β_data are "
                "the exact inversion of that sampled-data loop, not eqs. (19)-(20) as printed "
                "(which read C low by about ω²T/2)"
          : "continuous loop assumed (no sample rate given or correction off): C_data, β_data by "
            "eqs. (19)-(20) as printed");
  fit.effects = options.effects;
  const bool known_effects = !active_effects(fit.effects).empty();
  if (known_effects) {
    fit.notes.push_back(
        "known effects: " + effects_text(fit.effects) +
        ". The sine runs' local points were corrected for them: C_data, β_data read θ against the "
        "plant input S(Z(v(t − τ))) + n(θ, θ̇) (describing function of the fundamental, "
        "effect_sine_point.hpp) instead of against the command; the α_data are the command's "
        "(36). Every simulation (validation, time-domain fit) includes these effects");
  }
}

/// Stage 2's notes on what the local points could not use, and why.
void local_point_notes(const FitPipelineOptions& options, std::size_t skipped_controller,
                       std::size_t off_rate_runs, DatasetFit& fit) {
  if (skipped_controller > 0) {
    fit.notes.push_back(std::to_string(skipped_controller) +
                        " sine run(s) were not under a pure P law (kp > 0, ki = kd = 0), which the "
                        "local linear model (19)-(20) assumes; they were left out of identification");
  }
  std::size_t first_order = 0;
  for (const auto& sp : fit.sine_points) {
    first_order += sp.point.sample_period_s > 0.0 && sp.point.physical && !sp.point.sampled_exact;
  }
  if (first_order > 0) {
    fit.notes.push_back(std::to_string(first_order) +
                        " sine point(s): the exact sampled-data inversion did not converge; the "
                        "first-order correction C = (C_data + ω²T/2)/(1 − C_data·T/2) was used");
  }
  if (off_rate_runs > 0) {
    fit.notes.push_back(std::to_string(off_rate_runs) +
                        " sine run(s) are not sampled at the loop period T: the digital-loop "
                        "correction assumes one controller tick per sample; check sample_rate_hz");
  }
  std::size_t n_nonphysical = 0;
  for (const auto& sp : fit.sine_points) n_nonphysical += sp.point.physical ? 0 : 1;
  if (n_nonphysical > 0) {
    fit.notes.push_back(std::to_string(n_nonphysical) +
                        " sine point(s) are non-physical (A1² + A2(A2 − Ar) ≤ 0: negative C_data, "
                        "β_data) and were excluded, as the paper does");
  }
  if (fit.sine_points.empty()) {
    fit.notes.push_back(options.time_domain
                            ? "no sine runs with freq_hz under a P law: the local points (19)-(20) "
                              "and the global fit (22) need them; the models are identified in the "
                              "time domain instead"
                            : "no sine runs with freq_hz under a P law: no local or global linear "
                              "model, no α-invariant model can be identified from this dataset");
  }
}

}  // namespace

void FitPipelineOptions::validate() const {
  if (!(settle_fraction >= 0.0 && settle_fraction < 1.0)) {
    detail::bad("FitPipelineOptions::settle_fraction", "a fraction in [0, 1)", settle_fraction);
  }
  if (n_breakpoints < 2 || n_breakpoints > kMaxBreakpoints) {
    detail::bad("FitPipelineOptions::n_breakpoints",
                "2 to " + std::to_string(kMaxBreakpoints) + " breakpoints",
                static_cast<double>(n_breakpoints));
  }
  if (!std::isnan(loop_period_s) && !(loop_period_s >= 0.0 && std::isfinite(loop_period_s))) {
    detail::bad("FitPipelineOptions::loop_period_s",
                "NaN (from the sample rate), 0 (off) or a period > 0 [s]", loop_period_s);
  }
  if (disturbance_passes < 0 || disturbance_passes > 100) {
    detail::bad("FitPipelineOptions::disturbance_passes", "0 (off) to 100 passes",
                static_cast<double>(disturbance_passes));
  }
  validate_effects(effects, "FitPipelineOptions::effects.");
}

bool DatasetFit::usable() const {
  if (alpha.ok) return true;
  for (const PoseFit& p : poses) {
    if (p.linear.valid) return true;
  }
  return false;
}

JointModelAtPose DatasetFit::model_for_pose(std::size_t pose) const {
  JointModelAtPose m;
  const PoseFit& p = poses[pose];
  m.inertia = p.inertia;
  if (has_inertia_model) {
    m.c_linear = inertia.model.damping(p.inertia);
    m.beta_tilde_linear = inertia.model.beta_tilde(p.inertia);
  } else {
    m.c_linear = p.linear.c_linear;
    m.beta_tilde_linear = p.linear.beta_tilde_linear;
  }
  m.alpha = alpha.model;
  m.use_alpha = alpha.ok;
  m.effects = effects;
  return m;
}

void group_runs_by_pose(const Dataset& dataset, DatasetFit& fit) {
  const std::size_t n_runs = dataset.runs.size();
  std::map<std::pair<long, long>, std::size_t> pose_index;
  for (std::size_t i = 0; i < n_runs; ++i) {
    const RunInfo& run = dataset.runs[i];
    const bool has_pose = run.gamma1_deg && run.gamma2_deg;
    const std::pair<long, long> key =
        has_pose ? std::make_pair(std::lround(*run.gamma1_deg * 100), std::lround(*run.gamma2_deg * 100))
                 : std::make_pair(std::numeric_limits<long>::min(), 0L);
    auto it = pose_index.find(key);
    if (it == pose_index.end()) {
      it = pose_index.emplace(key, fit.poses.size()).first;
      PoseFit p;
      if (has_pose) {
        p.gamma1_deg = run.gamma1_deg;
        p.gamma2_deg = run.gamma2_deg;
      }
      fit.poses.push_back(p);
    }
    fit.poses[it->second].runs.push_back(i);
  }
}

std::vector<std::size_t> pose_of_runs(const DatasetFit& fit, std::size_t n_runs) {
  std::vector<std::size_t> run_pose(n_runs);
  for (std::size_t p = 0; p < fit.poses.size(); ++p) {
    for (std::size_t i : fit.poses[p].runs) run_pose.at(i) = p;
  }
  return run_pose;
}

std::vector<std::vector<LocalLinearPoint>> points_by_pose(const DatasetFit& fit) {
  std::vector<std::vector<LocalLinearPoint>> pose_points(fit.poses.size());
  for (const SineRunPoint& sp : fit.sine_points) pose_points.at(sp.pose).push_back(sp.point);
  return pose_points;
}

void fit_local_linear_points(const Dataset& dataset, const std::vector<RunData>& data,
                             const FitPipelineOptions& options, DatasetFit& fit) {
  const std::size_t n_runs = dataset.runs.size();
  const std::vector<std::size_t> run_pose = pose_of_runs(fit, n_runs);
  detail::ProgressReporter progress(options);
  set_loop_period_and_effects(dataset, options, fit);
  const bool known_effects = !active_effects(fit.effects).empty();
  std::size_t off_rate_runs = 0;
  std::size_t skipped_controller = 0;
  for (std::size_t i = 0; i < n_runs; ++i) {
    progress("local fits", i, n_runs);
    const RunInfo& run = dataset.runs[i];
    if (!is_periodic_kind(run)) continue;
    const Controller& ctl = run.controller;
    if (!(ctl.kp > 0.0) || ctl.ki != 0.0 || ctl.kd != 0.0) {
      ++skipped_controller;
      continue;
    }
    if (fit.kp == 0.0) fit.kp = ctl.kp;
    const RunData& d = data[i];
    const double f = *run.freq_hz, w = 2.0 * kPi * f;
    const double duration = d.t.back() - d.t.front();
    const IndexRange win = steady_state_window(d.t, f, options.settle_fraction * duration);
    if (win.size() < 8) {
      fit.notes.push_back("run " + run.file + ": shorter than one period after the transient; skipped");
      continue;
    }
    const SineFit fr = fit_sine(d.t.data() + win.begin, d.r.data() + win.begin, win.size(), w);
    const SineFit ft = fit_sine(d.t.data() + win.begin, d.theta.data() + win.begin, win.size(), w);
    if (!fr.valid || !ft.valid || !(fr.amplitude() > 0.0)) continue;
    if (const std::string why = declared_frequency_mismatch(run, d, fr); !why.empty()) {
      fit.notes.push_back(why);
      continue;
    }
    // Express θ in the frame where r = Ar sin ωt (eq. (14)).
    const double phi = wrap_rad(ft.phase_rad() - fr.phase_rad());
    const double a0 = ft.amplitude(), ar = fr.amplitude();
    SineRunPoint sp;
    sp.run = i;
    sp.pose = run_pose[i];
    if (fit.loop_period_s > 0.0 && d.t.size() > 1) {
      const double dt_s = (d.t.back() - d.t.front()) / static_cast<double>(d.t.size() - 1);
      if (std::abs(dt_s / fit.loop_period_s - 1.0) > 0.01) ++off_rate_runs;
    }
    // Known effects or known inputs (disturbance_v, torque_enable): the point against the plant
    // input u of plant_input.hpp (effect_sine_point.hpp); gain and phase stay those of θ against r.
    const bool known_inputs = !KnownInputSeries::of_run(d).empty();
    sp.point = known_effects || known_inputs
                   ? sine_point_with_effects(d, win, f, ctl.kp, fit.loop_period_s, fit.effects)
                   : local_linear_point(f, a0 * std::sin(phi), a0 * std::cos(phi), ar, ctl.kp,
                                        fit.loop_period_s);
    sp.gain = a0 / ar;
    sp.phase_deg = rad_to_deg(phi);
    fit.sine_points.push_back(sp);
  }
  progress("local fits", n_runs, n_runs);
  local_point_notes(options, skipped_controller, off_rate_runs, fit);
}

void fit_global_linear_models(DatasetFit& fit) {
  const std::vector<std::vector<LocalLinearPoint>> pose_points = points_by_pose(fit);
  for (std::size_t p = 0; p < fit.poses.size(); ++p) {
    const auto& pts = pose_points[p];
    if (pts.empty()) continue;
    double f_res = pts.front().freq_hz, best_gain = -1.0;
    for (const auto& sp : fit.sine_points) {
      if (sp.pose == p && sp.gain > best_gain) {
        best_gain = sp.gain;
        f_res = sp.point.freq_hz;
      }
    }
    // The paper fits (22) on 3-4.5 Hz around the 3.4 Hz resonance (paper-notes): the band is
    // [f_res/1.3, 1.3 f_res] around the frequency of largest measured gain.
    PoseFit& pose = fit.poses[p];
    pose.band_lo_hz = f_res / 1.3;
    pose.band_hi_hz = f_res * 1.3;
    std::vector<LocalLinearPoint> band;
    for (const auto& q : pts) {
      if (q.physical && q.freq_hz >= pose.band_lo_hz - 1e-9 && q.freq_hz <= pose.band_hi_hz + 1e-9) {
        band.push_back(q);
      }
    }
    if (band.size() < 2) {
      band.clear();
      for (const auto& q : pts) {
        if (q.physical) band.push_back(q);
      }
      pose.band_lo_hz = band.empty() ? 0.0 : band.front().freq_hz;
      pose.band_hi_hz = band.empty() ? 0.0 : band.back().freq_hz;
    }
    pose.linear = global_linear_fit(band, fit.kp);
    if (pose.linear.valid && (pose.linear.c_linear <= 0.0 || pose.linear.beta_linear <= 0.0)) {
      pose.linear.valid = false;
    }
    if (pose.linear.valid) pose.linear_source = "sine (22)";
  }
}

void fit_inertia_across_poses(const FitPipelineOptions& options, DatasetFit& fit) {
  detail::ProgressReporter progress(options);
  std::vector<InertiaPose> ipose;
  for (const PoseFit& pose : fit.poses) {
    if (pose.gamma1_deg && pose.linear.valid) {
      InertiaPose ip;
      ip.gamma1_rad = deg_to_rad(*pose.gamma1_deg);
      ip.gamma2_rad = deg_to_rad(*pose.gamma2_deg);
      ip.c_linear = pose.linear.c_linear;
      ip.beta_tilde_linear = pose.linear.beta_tilde_linear;
      ipose.push_back(ip);
    }
  }
  if (ipose.size() >= 6) {
    progress("inertia fit", 0, 1);
    fit.inertia = fit_inertia_model(ipose, InertiaFitOptions{});
    progress("inertia fit", 1, 1);
    fit.has_inertia_model = fit.inertia.converged;
    if (!fit.has_inertia_model) {
      fit.notes.push_back("inertia model fit did not converge: " + fit.inertia.message +
                          "; the per-pose linear models are used");
    }
  } else {
    fit.notes.push_back("inertia model (6) skipped: it needs global linear fits at 6 or more poses "
                        "with gamma1_deg/gamma2_deg, this dataset has " +
                        std::to_string(ipose.size()) + "; per-pose models (I = 1) are fitted instead");
  }
  for (PoseFit& pose : fit.poses) {
    if (fit.has_inertia_model && pose.gamma1_deg) {
      pose.inertia = fit.inertia.model.inertia.inertia(deg_to_rad(*pose.gamma1_deg),
                                                       deg_to_rad(*pose.gamma2_deg));
    } else {
      pose.inertia = 1.0;
    }
  }
}

void fit_alpha_invariant_model(const FitPipelineOptions& options, DatasetFit& fit) {
  const std::vector<std::vector<LocalLinearPoint>> pose_points = points_by_pose(fit);
  detail::ProgressReporter progress(options);
  std::vector<AlphaFitPose> apose;
  std::vector<std::size_t> apose_pose;  // apose index → fit.poses index
  for (std::size_t p = 0; p < fit.poses.size(); ++p) {
    if (pose_points[p].empty()) continue;
    apose.push_back(AlphaFitPose{fit.poses[p].inertia, pose_points[p]});
    apose_pose.push_back(p);
  }
  if (!apose.empty()) {
    AlphaFitOptions aopt;
    aopt.kp = fit.kp;
    aopt.n_breakpoints = options.n_breakpoints;
    aopt.refine = options.refine_breakpoints;
    progress("alpha breakpoint search", 0, 1);
    fit.alpha = fit_alpha_model(apose, aopt);
    if (fit.alpha.ok) fit.alpha_source = "sine (2.3.5)";
    if (fit.alpha.ok && fit.has_inertia_model && options.alpha_consistent_inertia) {
      refit_inertia_with_alpha_model(fit, apose, apose_pose, aopt);
    }
    progress("alpha breakpoint search", 1, 1);
    if (!fit.alpha.ok) fit.notes.push_back("α-invariant model not fitted: " + fit.alpha.message);
    identifiability_notes(fit);
    if (!fit.has_inertia_model && apose.size() > 1) {
      fit.notes.push_back("without an inertia model the α-model is one model for all poses (I = 1)");
    }
  }
}

void choose_model_simulation(const std::vector<RunData>& data, const FitPipelineOptions& options,
                             DatasetFit& fit) {
  // A digital loop (the local points were corrected for it, or the dataset gives a sample rate):
  // simulate it as one, the command held over each tick, when the runs are sampled on the loop's
  // grid; otherwise the continuous law (43). On the grid: every interval a whole number of periods
  // (to 5 %), and at most 1 % of them longer than one: a recording of a loop that skipped a few
  // late ticks (omni_ctl under load: t is the tick's deadline, a skipped deadline a gap of 2T, 3T)
  // is still that loop. The simulation ticks through a gap as the loop would have.
  if (fit.loop_period_s > 0.0) {
    const double period = fit.loop_period_s;
    bool on_grid = true;
    std::size_t intervals = 0, gaps = 0;
    for (const RunData& d : data) {
      for (std::size_t k = 1; k < d.size() && on_grid; ++k) {
        const double ticks = (d.t[k] - d.t[k - 1]) / period;
        const double whole = std::round(ticks);
        on_grid = whole >= 1.0 && std::abs(ticks - whole) < 0.05;
        ++intervals;
        gaps += whole > 1.0 ? 1 : 0;
      }
    }
    on_grid = on_grid && static_cast<double>(gaps) <= 0.01 * static_cast<double>(intervals);
    if (on_grid) fit.simulation.loop_period_s = period;
    std::string note;
    if (!on_grid) {
      note = "runs not sampled uniformly at the loop period: models simulated with the continuous "
             "law (43)";
    } else {
      note = "models simulated as the digital loop at " + format_g(1.0 / period) +
             " Hz (command held over each tick)";
      if (gaps > 0) {
        note += "; " + std::to_string(gaps) + " of " + std::to_string(intervals) +
                " sample intervals span skipped ticks (whole periods): simulated on the loop's grid";
      }
    }
    fit.notes.push_back(note);
  }
  if (options.time_domain && fit.sine_points.empty() && !(fit.simulation.loop_period_s > 0.0)) {
    // Continuous law on slow, irregular samples: RK4 steps as long as the median sample interval
    // (at least 1 ms): the references are interpolated from the samples anyway.
    std::vector<double> dts;
    for (const RunData& d : data) {
      for (std::size_t k = 1; k < d.size(); ++k) dts.push_back(d.t[k] - d.t[k - 1]);
    }
    if (!dts.empty()) fit.simulation.max_step_s = std::max(1e-3, percentile(dts, 50.0));
  }
}

/// One run simulated with both models under its own controller (the linear one always, the α one
/// when fitted) and compared with the measurement.
RunValidation validate_run(const Dataset& dataset, const std::vector<RunData>& data,
                           const FitPipelineOptions& options, const DatasetFit& fit,
                           std::size_t i, std::size_t pose) {
  RunValidation rv;
  rv.run = i;
  const RunInfo& run = dataset.runs[i];
  const RunData& d = data[i];
  JointModelAtPose m = fit.model_for_pose(pose);
  if (!(m.c_linear > 0.0) || !(m.beta_tilde_linear > 0.0)) {
    rv.message = "no linear model for this run's pose";
    return rv;
  }
  // The run's known inputs (disturbance_v, torque_enable) enter the plant (plant_input.hpp).
  const Controller& ctl = run.controller;
  const InitialState x0 = initial_state_of(d);
  m.use_alpha = false;
  const SimulationResult lin = simulate_recorded_run(m, ctl, d, x0, fit.simulation);
  SimulationResult alp;
  if (fit.alpha.ok) {
    m.use_alpha = true;
    alp = simulate_recorded_run(m, ctl, d, x0, fit.simulation);
  }
  if (!lin.ok) {
    rv.message = "linear simulation failed: " + lin.message;
    return rv;
  }
  rv.simulated = true;
  const bool periodic = is_periodic_kind(run);
  IndexRange win;
  if (periodic) {
    const double duration = d.t.back() - d.t.front();
    win = steady_state_window(d.t, *run.freq_hz, options.settle_fraction * duration);
  }
  auto compare = [&](const SimulationResult& sim, RunErrors& e) {
    if (!sim.ok) return;
    e.simulated = true;
    e.abs = abs_error_stats(d.theta, sim.theta, 0, d.size());
    double num = 0.0, den = 0.0;
    for (std::size_t k = 0; k < d.size(); ++k) {
      num += std::pow(sim.theta[k] - d.theta[k], 2);
      den += d.theta[k] * d.theta[k];
    }
    e.rel_position_error = den > 0.0 ? std::sqrt(num / den) : kNaN;
    if (periodic) {
      e.fundamental =
          fundamental_error(d.t, d.r, d.theta, sim.theta, *run.freq_hz, win.begin, win.end);
    }
  };
  compare(lin, rv.linear);
  compare(alp, rv.alpha);
  return rv;
}

void simulate_validation_runs(const Dataset& dataset, const std::vector<RunData>& data,
                              const FitPipelineOptions& options, DatasetFit& fit) {
  const std::size_t n_runs = dataset.runs.size();
  const std::vector<std::size_t> run_pose = pose_of_runs(fit, n_runs);
  detail::ProgressReporter progress(options);
  fit.validation.resize(n_runs);
  std::mutex progress_mutex;  // the count and its report together, so the count never goes back
  std::size_t done = 0;
  progress("validation simulations", 0, n_runs);
  common::parallel_for(n_runs, options.threads, [&](std::size_t i) {
    fit.validation[i] = validate_run(dataset, data, options, fit, i, run_pose[i]);
    const std::lock_guard<std::mutex> lock(progress_mutex);
    progress("validation simulations", ++done, n_runs);
  });
}

void summarise_validation(const Dataset& dataset, DatasetFit& fit) {
  // Per pose: Table 8 (90th percentile over the sweep) and Table 11 (median, p90 of |error|);
  // then the median of each figure over the poses.
  auto pose_errors = [&](const PoseFit& pose, RunErrors RunValidation::*model) {
    std::vector<double> mag, phase, step_median, step_p90;
    for (std::size_t i : pose.runs) {
      const RunErrors& e = fit.validation[i].*model;
      if (!e.simulated) continue;
      if (e.fundamental.valid) {
        mag.push_back(e.fundamental.magnitude_abs_error);
        phase.push_back(e.fundamental.phase_abs_error_deg);
      }
      if (is_step_kind(dataset.runs[i])) {
        step_median.push_back(e.abs.median);
        step_p90.push_back(e.abs.p90);
      }
    }
    return ModelErrors{finite_p90(mag), finite_p90(phase), finite_median(step_median),
                       finite_median(step_p90)};
  };
  auto median_over_poses = [&](ModelErrors PoseFit::*model) {
    std::vector<double> mag, phase, step_median, step_p90;
    for (const PoseFit& pose : fit.poses) {
      const ModelErrors& e = pose.*model;
      mag.push_back(e.magnitude_p90);
      phase.push_back(e.phase_p90_deg);
      step_median.push_back(e.step_median_abs_err);
      step_p90.push_back(e.step_p90_abs_err);
    }
    return ModelErrors{finite_median(mag), finite_median(phase), finite_median(step_median),
                       finite_median(step_p90)};
  };
  for (PoseFit& pose : fit.poses) {
    pose.linear_errors = pose_errors(pose, &RunValidation::linear);
    pose.alpha_errors = pose_errors(pose, &RunValidation::alpha);
  }
  fit.linear_errors = median_over_poses(&PoseFit::linear_errors);
  fit.alpha_errors = median_over_poses(&PoseFit::alpha_errors);
  // Median relative position error over all simulated runs, and a plain warning when the model
  // class clearly misses something (more than 20 % of the motion unexplained).
  auto rel_median = [&](RunErrors RunValidation::*model) {
    std::vector<double> rel;
    for (const RunValidation& v : fit.validation) {
      if ((v.*model).simulated) rel.push_back((v.*model).rel_position_error);
    }
    return finite_median(rel);
  };
  fit.linear_errors.rel_position_error_median = rel_median(&RunValidation::linear);
  fit.alpha_errors.rel_position_error_median = rel_median(&RunValidation::alpha);
  const double best = fit.alpha.ok ? fit.alpha_errors.rel_position_error_median
                                   : fit.linear_errors.rel_position_error_median;
  if (best > 0.2) {
    fit.notes.push_back(
        "the fitted models do not describe these runs: the median relative position error of "
        "the simulation is " + std::to_string(static_cast<int>(std::lround(100.0 * best))) +
        " %, so a physical effect outside the model dominates (gravity, saturation, friction, "
        "...); `omni_fit diagnose` tests the catalogue of effects and adds the one that explains "
        "the gap");
  }
}

void describe_fit(DatasetFit& fit) {
  if (!fit.usable()) {
    fit.message = "no model could be identified: no pose has a linear model and there is no "
                  "α-model (the notes say why)";
    return;
  }
  std::size_t modelled = 0, from_sine = 0;
  for (const PoseFit& p : fit.poses) {
    modelled += p.linear.valid || (fit.has_inertia_model && p.gamma1_deg) ? 1 : 0;
    from_sine += p.linear.valid && p.linear_source == "sine (22)" ? 1 : 0;
  }
  fit.message = "identified: a linear model at " + std::to_string(modelled) + " of " +
                std::to_string(fit.poses.size()) + " poses (" + std::to_string(from_sine) +
                " by the sine runs (22)" +
                (fit.has_inertia_model ? ", every pose with angles by the inertia model (27)-(29))"
                                       : ", no inertia model)") +
                (fit.alpha.ok ? ", the α-model (" + fit.alpha_source + ")" : ", no α-model");
}

DatasetFit fit_sine_stages(const Dataset& dataset, const std::vector<RunData>& data,
                           const FitPipelineOptions& options) {
  DatasetFit fit;
  group_runs_by_pose(dataset, fit);
  fit_local_linear_points(dataset, data, options, fit);
  fit_global_linear_models(fit);
  fit_inertia_across_poses(options, fit);
  fit_alpha_invariant_model(options, fit);
  choose_model_simulation(data, options, fit);
  return fit;
}

DatasetFit fit_dataset(const Dataset& dataset, const std::vector<RunData>& data,
                       const FitPipelineOptions& options) {
  options.validate();
  DatasetFit fit = fit_sine_stages(dataset, data, options);
  remove_known_disturbance_response(dataset, data, options, fit);
  if (options.time_domain) fit_time_domain_poses(dataset, data, options, fit);
  if (options.run_validation) {
    simulate_validation_runs(dataset, data, options, fit);
    summarise_validation(dataset, fit);
  }
  describe_fit(fit);
  return fit;
}

}  // namespace alphainv
