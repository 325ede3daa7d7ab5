/// \file fit_report.cpp
/// report.md of a dataset fit (fit_report.hpp) and DatasetFit's brief and full reports.

#include "alphainv/identify/fit_report.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "alphainv/identify/inertia_fit.hpp"

namespace alphainv {

namespace {

std::string fmt(double x, const char* f = "%.4g") { return report_number(x, f); }

/// Table cells of one model's errors: magnitude p90 | phase p90 | step median | step p90.
std::string error_cells(const ModelErrors& e) {
  return fmt(e.magnitude_p90) + " | " + fmt(e.phase_p90_deg) + " | " + fmt(e.step_median_abs_err) +
         " | " + fmt(e.step_p90_abs_err);
}

std::string pose_label(const PoseFit& p) {
  if (!p.gamma1_deg) return "(no pose)";
  return fmt(*p.gamma1_deg, "%.2f") + "° / " + fmt(*p.gamma2_deg, "%.2f") + "°";
}

/// remove_known_disturbance_response()'s outcome in one phrase.
std::string disturbance_correction_text(const DatasetFit& fit) {
  const KnownDisturbanceCorrection& d = fit.disturbance_correction;
  if (d.passes == 0) {
    return "not taken out of the " + std::to_string(d.runs_with_disturbance) +
           " sine run(s) with a disturbance_v (off, or the simulations failed)";
  }
  return "taken out of " + std::to_string(d.runs_corrected) + " of " +
         std::to_string(d.runs_with_disturbance) + " sine run(s) with a disturbance_v, " +
         std::to_string(d.passes) + " pass(es), last point change " +
         fmt(100 * d.last_point_change, "%.3g") + " %, kept pass " +
         std::to_string(d.chosen_pass) + " (RMS on those runs " +
         fmt(d.first_pass_rms_rad, "%.3g") + " → " + fmt(d.chosen_rms_rad, "%.3g") + " rad)";
}

/// Title, the dataset, the known effects and the notes.
void header_section(std::ostringstream& r, const Dataset& ds, const DatasetFit& fit,
                    const FitReportInfo& info) {
  r << "# omni_fit report\n\n";
  if (info.dataset_dirs.size() > 1) {
    r << "Datasets fitted together:";
    for (std::size_t k = 0; k < info.dataset_dirs.size(); ++k) {
      r << (k == 0 ? " `" : " + `") << info.dataset_dirs[k] << "`";
    }
  } else {
    r << "Dataset: `" << ds.dir.string() << "`";
  }
  r << " (" << ds.runs.size() << " runs, " << fit.poses.size() << " poses, position unit "
    << ds.position_unit << ", command unit " << ds.command_unit << "), hash "
    << info.dataset_hash
    << (info.dataset_dirs.size() > 1 ? " (of every folder's dataset.json and every run file)" : "")
    << ".\n\n";
  if (!active_effects(fit.effects).empty()) {
    r << "**Fitted with known effects** (" << info.effects_source
      << "): " << effects_text(fit.effects)
      << ". The local points of the sine runs were corrected for them (C_data, β_data against the "
         "plant input through the effects), the validation simulations include them, and "
         "model.json carries them.\n\n";
  }
  if (fit.disturbance_correction.runs_with_disturbance > 0) {
    r << "**Known disturbance response** (stage 6a): " << disturbance_correction_text(fit)
      << ".\n\n";
  }
  if (!fit.notes.empty()) {
    r << "## What the data could and could not support\n\n";
    for (const auto& n : fit.notes) r << "- " << n << "\n";
    r << "\n";
  }
}

/// Section 2.2.4: the local linear points (19), (20), (36) of the sine runs.
void local_points_section(std::ostringstream& r, const Dataset& ds, const DatasetFit& fit) {
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
      << fmt(sp.point.freq_hz) << " | " << fmt(sp.gain) << " | " << fmt(sp.phase_deg, "%.2f")
      << " | " << fmt(sp.point.c_data) << " | " << fmt(sp.point.beta_data) << " | "
      << fmt(sp.point.alpha_data) << " | " << (sp.point.physical ? "yes" : "**no**") << " |\n";
  }
}

/// Section 2.2.5: the global linear model (22) per pose.
void global_linear_section(std::ostringstream& r, const DatasetFit& fit) {
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
  r << "\nBand: [f_res/1.3, 1.3 f_res] around the frequency of largest measured gain (the paper "
       "uses 3–4.5 Hz around its 3.4 Hz resonance), all physical points when fewer than two fall "
       "in it.\n";
}

/// Section 2.2.6: the inertia model (6), (27)-(29), when there is one.
void inertia_section(std::ostringstream& r, const DatasetFit& fit) {
  if (fit.has_inertia_model) {
    const auto& s = fit.inertia;
    r << "\n## Inertia model (eqs. 6, 27–29, Ceres)\n\n| parameter | value | standard error | "
         "poorly determined |\n|---|---|---|---|\n";
    for (int k = 0; k < kInertiaFitParameterCount; ++k) {
      const auto i = static_cast<std::size_t>(k);
      r << "| " << inertia_fit_parameter_name(k) << " | " << fmt(s.parameters[i], "%.5g") << " | "
        << fmt(s.standard_errors[i], "%.3g") << " | " << (s.poorly_determined[i] ? "yes" : "no")
        << " |\n";
    }
    r << "\nRMS relative error of the model: C_linear " << fmt(100 * s.rms_relative_c, "%.2f")
      << " %, β̃_linear " << fmt(100 * s.rms_relative_beta_tilde, "%.2f") << " %.";
    if (!s.warning.empty()) r << " Warning: " << s.warning;
    r << "\n";
  }
}

/// Section 2.3.5: the α-invariant model (38)-(42), when there is one.
void alpha_section(std::ostringstream& r, const DatasetFit& fit) {
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
      << " at α = " << fmt(a.beta_alpha[1]) << ".";
    // Only what was measured: the relative errors on the local points (sine branch).
    if (std::isfinite(fit.alpha.c_rms_relative) && std::isfinite(fit.alpha.beta_rms_relative)) {
      r << " RMS relative error on the data: C " << fmt(100 * fit.alpha.c_rms_relative, "%.2f")
        << " %, β̃ " << fmt(100 * fit.alpha.beta_rms_relative, "%.2f") << " %.";
    } else {
      r << " Identifiable: relative SE ≤ 10 % and no correlation above 0.95 with another "
           "coefficient (output-error covariance; serially correlated residuals make SEs lower "
           "bounds).";
    }
    r << "\n";
  }
}

/// Section 2.4: Table 8 and Table 11 style errors per pose, and per run.
void validation_section(std::ostringstream& r, const Dataset& ds, const DatasetFit& fit) {
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
  r << "\nRelative position error ‖θ_sim − θ‖/‖θ‖ per run:\n\n| run | linear | α-model "
       "|\n|---|---|---|\n";
  for (const auto& v : fit.validation) {
    if (!v.simulated) continue;
    r << "| " << ds.runs[v.run].file << " | " << fmt(100 * v.linear.rel_position_error, "%.4f")
      << " % | " << fmt(100 * v.alpha.rel_position_error, "%.4f") << " % |\n";
  }
}

/// "mag p90 0.5078, phase p90 12.78°, step median 0.004352, step p90 0.02305, relative position
/// error median 0.1794" of one model's validation errors.
std::string errors_text(const ModelErrors& e) {
  return "mag p90 " + fmt(e.magnitude_p90) + ", phase p90 " + fmt(e.phase_p90_deg) +
         "°, step median " + fmt(e.step_median_abs_err) + ", step p90 " +
         fmt(e.step_p90_abs_err) + ", relative position error median " +
         fmt(e.rel_position_error_median);
}

/// "a, b, c" of `n` numbers.
template <typename Array>
std::string list_text(const Array& values, std::size_t n) {
  std::string out;
  for (std::size_t k = 0; k < n; ++k) out += (k > 0 ? ", " : "") + fmt(values[k]);
  return out;
}

}  // namespace

std::string DatasetFit::brief_report() const {
  std::size_t runs = 0, modelled = 0, nonphysical = 0;
  for (const PoseFit& p : poses) {
    runs += p.runs.size();
    modelled += p.linear.valid || (has_inertia_model && p.gamma1_deg) ? 1 : 0;
  }
  for (const SineRunPoint& sp : sine_points) nonphysical += sp.point.physical ? 0 : 1;
  std::string out = std::string("dataset fit: ") + (usable() ? "usable" : "NOT usable") + "; " +
                    std::to_string(runs) + " runs, " + std::to_string(poses.size()) + " poses, " +
                    std::to_string(sine_points.size()) + " sine points (" +
                    std::to_string(nonphysical) + " non-physical); linear model at " +
                    std::to_string(modelled) + " of " + std::to_string(poses.size()) + " poses, " +
                    (has_inertia_model ? "inertia model, " : "no inertia model, ") +
                    (alpha.ok ? "α-model (" + alpha_source + ")" : std::string("no α-model"));
  if (!validation.empty()) {
    out += "; step median |θ_sim − θ|: linear " + fmt(linear_errors.step_median_abs_err) +
           ", α " + fmt(alpha_errors.step_median_abs_err);
  }
  return out;
}

std::string DatasetFit::full_report() const {
  std::string out = brief_report() + "\n" + message + "\n";
  out += "  local points (19)-(20), (36): " + std::to_string(sine_points.size()) +
         " from the sine runs, kp " + fmt(kp) + ", " +
         (loop_period_s > 0.0 ? "digital loop T = " + fmt(1e3 * loop_period_s) + " ms"
                              : std::string("continuous loop")) +
         (active_effects(effects).empty() ? "" : "; known effects: " + effects_text(effects)) +
         "\n";
  if (disturbance_correction.runs_with_disturbance > 0) {
    out += "  known disturbance response: " + disturbance_correction_text(*this) + "\n";
  }
  for (const PoseFit& p : poses) {
    if (!p.linear.valid) continue;
    out += "  linear model at " + pose_label(p) + ": C_linear " + fmt(p.linear.c_linear) +
           " 1/s, β̃_linear " + fmt(p.linear.beta_tilde_linear) + ", I " + fmt(p.inertia) + " (" +
           p.linear_source + ")\n";
  }
  out += "  " + (has_inertia_model ? inertia.brief_report() : std::string("inertia model: none")) +
         "\n";
  if (alpha.ok) {
    const AlphaModel& a = alpha.model;
    out += "  α-model (" + alpha_source + "): N = " + std::to_string(a.n_breakpoints) +
           ", α_n = " + list_text(a.alpha, a.n_breakpoints) + "; C_n1 = " +
           list_text(a.c_n1, a.n_breakpoints) + "; β̃_n1 = " + list_text(a.beta_n1, 2) +
           " at α = " + list_text(a.beta_alpha, 2) +
           (std::isfinite(alpha.c_rms_relative) && std::isfinite(alpha.beta_rms_relative)
                ? "; RMS relative error C " + fmt(100 * alpha.c_rms_relative, "%.2f") + " %, β̃ " +
                      fmt(100 * alpha.beta_rms_relative, "%.2f") + " %"
                : std::string("; no local points to measure relative errors on")) +
           "\n";
  } else {
    out += "  α-model: not fitted" + (alpha.message.empty() ? "" : ": " + alpha.message) + "\n";
  }
  if (validation.empty()) {
    out += "  validation: not run\n";
  } else {
    out += "  validation, linear model: " + errors_text(linear_errors) + "\n";
    out += "  validation, α-model: " + errors_text(alpha_errors) + "\n";
  }
  if (!notes.empty()) out += "  notes:\n";
  for (const std::string& n : notes) out += "    - " + n + "\n";
  return out;
}

std::string report_number(double x, const char* format) {
  if (!std::isfinite(x)) return "–";
  char b[64];
  std::snprintf(b, sizeof b, format, x);
  return b;
}

std::string fit_report_markdown(const Dataset& dataset, const DatasetFit& fit,
                                const FitReportInfo& info) {
  std::ostringstream r;
  header_section(r, dataset, fit, info);
  local_points_section(r, dataset, fit);
  global_linear_section(r, fit);
  inertia_section(r, fit);
  alpha_section(r, fit);
  validation_section(r, dataset, fit);
  r << info.appendix_markdown;
  return r.str();
}

}  // namespace alphainv
