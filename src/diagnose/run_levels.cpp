#include "alphainv/diagnose/run_levels.hpp"
#include "diagnose_stages.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "alphainv/diagnose/verdict.hpp"
#include "alphainv/error.hpp"
#include "alphainv/identify/output_error.hpp"
#include "alphainv/model/detail/field_checks.hpp"
#include "alphainv/simulate/recorded_run.hpp"
#include "common/format.hpp"
#include "common/parallel_for.hpp"

namespace alphainv {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string num(double x, const char* f) { return common::format(f, x); }

/// The levels of the friction family (run_levels.hpp, step 1): the named frictions' and the
/// discovered term's friction-like coefficients. (Not the viscous ones: the α-model's C carries
/// viscous damping, and a factor on it is the coefficient factors' business.)
constexpr double Effects::*kFrictionLevels[] = {
    &Effects::coulomb_v,
    &Effects::stribeck_coulomb_v,
    &Effects::stribeck_breakaway_v,
    &Effects::asymmetric_coulomb_pos_v,
    &Effects::asymmetric_coulomb_neg_v,
    &Effects::position_coulomb_v,
    &Effects::position_slope_v_per_rad,
    &Effects::discovered_sign_v,
    &Effects::discovered_stribeck_fast_v,
    &Effects::discovered_stribeck_mid_v,
    &Effects::discovered_stribeck_slow_v,
    &Effects::discovered_sign_pos_v,
    &Effects::discovered_lag_sign_v,
    &Effects::discovered_dahl_v,
};

using diagnose_detail::simulate_diagnosed_run;

/// Sum of squared θ − θ_sim over the run (NaN: the simulation failed).
double sse_of(const DiagnoseRun& run, const SimulationResult& s) {
  const RunData& d = *run.data;
  if (!s.ok || s.theta.size() != d.size()) return kNaN;
  double ss = 0.0;
  for (std::size_t k = 0; k < d.size(); ++k) ss += (d.theta[k] - s.theta[k]) * (d.theta[k] - s.theta[k]);
  return ss;
}

/// f fitted by output error on `run` (the model's level × f, all else fixed): f and its SE.
struct FactorFit {
  bool ok = false;
  double factor = kNaN, standard_error = kNaN;
};
FactorFit fit_factor(const DiagnoseRun& run, const Effects& e, const ModelScales& sc,
                     const std::optional<AlphaModel>& alpha, const RunLevelOptions& opt) {
  OutputErrorProblem pr;
  pr.runs.push_back({run.data, run.controller, 1.0, run.command_history, run.start});
  pr.parameters.push_back({"friction_level_factor", 1.0, 0.0, opt.max_factor});
  pr.simulation = opt.simulation;
  pr.max_residuals_per_run = opt.max_residuals_per_run;
  const JointModelAtPose base = run.model;
  pr.model = [base, e, sc, alpha](const double* p, std::size_t) {
    return diagnosed_model(base, with_friction_level(e, p[0]), sc, alpha);
  };
  OutputErrorOptions oo;
  oo.threads = 1;  // (the runs are fitted in parallel)
  oo.max_iterations = opt.max_iterations;
  const OutputErrorResult r = fit_output_error(pr, oo);
  FactorFit f;
  if (!r.ok || r.values.empty()) return f;
  f.ok = true;
  f.factor = r.values[0];
  if (!r.standard_errors.empty()) f.standard_error = r.standard_errors[0];
  return f;
}

}  // namespace

Effects with_friction_level(const Effects& e, double factor) {
  Effects out = e;
  for (double Effects::*m : kFrictionLevels) out.*m = e.*m * factor;
  return out;
}

bool has_friction_level(const Effects& e) {
  for (double Effects::*m : kFrictionLevels)
    if (e.*m != 0.0 && std::isfinite(e.*m)) return true;
  return false;
}

void RunLevelOptions::validate() const {
  if (!(significance >= 0.0 && significance < 1.0)) detail::bad("significance", "0 <= significance < 1", significance);
  if (!(std::isfinite(max_factor) && max_factor > 1.0)) detail::bad("max_factor", "> 1 (the model's own level is f = 1)", max_factor);
  if (max_iterations < 1) detail::bad("max_iterations", ">= 1", max_iterations);
  if (max_residuals_per_run < 10) detail::bad("max_residuals_per_run", ">= 10", static_cast<double>(max_residuals_per_run));
}

RunLevelsResult fit_run_levels(const std::vector<std::pair<DiagnoseRun, DiagnoseRun>>& halves,
                               const std::vector<DiagnoseRun>& whole, const Effects& effects,
                               const ModelScales& scales, const std::optional<AlphaModel>& alpha,
                               const RunLevelOptions& opt, double noise_floor) {
  const auto t0 = std::chrono::steady_clock::now();
  RunLevelsResult res;
  res.noise_floor = noise_floor;
  auto done = [&]() -> RunLevelsResult& {
    res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return res;
  };
  try {
    opt.validate();
  } catch (const Error& e) {
    res.message = std::string("invalid options: ") + e.what();
    return done();
  }
  if (!has_friction_level(effects)) {
    res.message = "the model has no friction level to vary between runs";
    return done();
  }
  if (halves.size() < 2 || whole.size() != halves.size()) {
    res.message = "fewer than 2 runs with two halves (or the halves and the runs do not match)";
    return done();
  }
  for (const DiagnoseRun& r : whole) {
    if (r.data == nullptr || r.data->size() < 50) {
      res.message = "run " + r.name + " has fewer than 50 samples";
      return done();
    }
  }
  const std::size_t n = halves.size();
  // 2. Each run's level on its whole run (output error fits the residual samples; on the whole
  // run its f can do worse than 1: then 1).
  std::vector<std::vector<double>> sims_before(n), sims_after(n);
  std::vector<double> sse_b(n, kNaN), sse_a(n, kNaN);
  std::vector<FactorFit> fits(n);
  common::parallel_for(n, opt.threads, [&](std::size_t i) {
    SimulationResult b = simulate_diagnosed_run(whole[i], effects, scales, alpha, opt.simulation);
    sse_b[i] = sse_of(whole[i], b);
    if (!std::isfinite(sse_b[i])) return;
    sims_before[i] = std::move(b.theta);
    FactorFit f = fit_factor(whole[i], effects, scales, alpha, opt);
    if (!f.ok) return;
    SimulationResult a = simulate_diagnosed_run(whole[i], with_friction_level(effects, f.factor), scales, alpha, opt.simulation);
    sse_a[i] = sse_of(whole[i], a);
    if (std::isfinite(sse_a[i]) && sse_a[i] > sse_b[i]) {
      f.factor = 1.0;
      f.standard_error = kNaN;
      sse_a[i] = sse_b[i];
      sims_after[i] = sims_before[i];
    } else if (std::isfinite(sse_a[i])) {
      sims_after[i] = std::move(a.theta);
    }
    fits[i] = f;
  });
  // 3. Held out in time: f from one half predicts the other (both ways), against f = 1.
  std::vector<double> sse_one(2 * n, kNaN), sse_own(2 * n, kNaN), count(2 * n, 0.0);
  common::parallel_for(2 * n, opt.threads, [&](std::size_t j) {
    const std::size_t i = j / 2;
    const DiagnoseRun& fit_on = (j % 2 == 0) ? halves[i].first : halves[i].second;
    const DiagnoseRun& judge = (j % 2 == 0) ? halves[i].second : halves[i].first;
    if (fit_on.data == nullptr || judge.data == nullptr || fit_on.data->size() < 50 || judge.data->size() < 50) return;
    count[j] = static_cast<double>(judge.data->size());
    sse_one[j] = sse_of(judge, simulate_diagnosed_run(judge, effects, scales, alpha, opt.simulation));
    const FactorFit f = fit_factor(fit_on, effects, scales, alpha, opt);
    if (!f.ok) return;
    sse_own[j] = sse_of(judge, simulate_diagnosed_run(judge, with_friction_level(effects, f.factor), scales, alpha, opt.simulation));
  });
  double s1 = 0.0, s2 = 0.0, c = 0.0;
  for (std::size_t j = 0; j < 2 * n; ++j) {
    if (!(count[j] > 0.0)) continue;
    if (!std::isfinite(sse_one[j]) || !std::isfinite(sse_own[j])) {
      res.message = "a held-out half did not simulate or its level did not fit (run " + halves[j / 2].first.name + ")";
      return done();
    }
    s1 += sse_one[j];
    s2 += sse_own[j];
    c += count[j];
  }
  if (!(c > 0.0)) {
    res.message = "no run has two halves of 50 samples";
    return done();
  }
  res.held_out_before = std::sqrt(s1 / c);
  res.held_out_after = std::sqrt(s2 / c);
  res.runs.resize(n);
  double sb = 0.0, sa = 0.0, m = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(sse_b[i]) || !std::isfinite(sse_a[i])) {
      res.message = "run " + whole[i].name + " did not simulate or its level did not fit";
      return done();
    }
    const double cnt = static_cast<double>(whole[i].data->size());
    res.runs[i].name = whole[i].name;
    res.runs[i].factor = fits[i].factor;
    res.runs[i].standard_error = fits[i].standard_error;
    res.runs[i].rms_before = std::sqrt(sse_b[i] / cnt);
    res.runs[i].rms_after = std::sqrt(sse_a[i] / cnt);
    sb += sse_b[i];
    sa += sse_a[i];
    m += cnt;
    res.factor_min = std::isnan(res.factor_min) ? res.runs[i].factor : std::min(res.factor_min, res.runs[i].factor);
    res.factor_max = std::isnan(res.factor_max) ? res.runs[i].factor : std::max(res.factor_max, res.runs[i].factor);
  }
  res.error_before = std::sqrt(sb / m);
  res.error_after = std::sqrt(sa / m);
  const std::vector<ResidualSeries> before = diagnose_detail::residual_series(whole, sims_before);
  const std::vector<ResidualSeries> after = diagnose_detail::residual_series(whole, sims_after);
  res.structure_before = structure_rms(before);
  res.structure_after = structure_rms(after);
  NoiseFloor floor;
  floor.rms = floor.white = noise_floor;
  res.fundamental_before = judge_residual(before, floor).fundamental_median;
  res.fundamental_after = judge_residual(after, floor).fundamental_median;
  if (noise_floor < res.error_before)
    res.gap_closed = (res.error_before - res.error_after) / (res.error_before - noise_floor);
  if (noise_floor < res.structure_before)
    res.structure_gap_closed = (res.structure_before - res.structure_after) / (res.structure_before - noise_floor);
  res.ok = true;
  res.varies = res.held_out_after <= (1.0 - opt.significance) * res.held_out_before;
  if (!res.varies) {
    res.message = "no run-by-run level predicts the held-out halves better than one level for every run "
                  "by the significance (" + num(res.held_out_before, "%.3g") + " -> " +
                  num(res.held_out_after, "%.3g") + ")";
  }
  return done();
}

std::string RunLevelsResult::brief_report() const {
  if (!ok) return "friction level run by run: not usable: " + message;
  std::ostringstream os;
  const double cut = held_out_before > 0 ? 100.0 * (1.0 - held_out_after / held_out_before) : kNaN;
  if (varies) {
    os << "the friction level differs between runs: " << num(factor_min, "%.2f") << "-"
       << num(factor_max, "%.2f") << " x the model's over " << runs.size() << " runs; held out "
       << num(held_out_before, "%.3g") << " -> " << num(held_out_after, "%.3g") << " (-"
       << num(cut, "%.0f") << " %)";
    if (std::isfinite(gap_closed)) os << "; closes " << num(100.0 * gap_closed, "%.0f") << " % of the gap to the noise floor";
    if (std::isfinite(structure_gap_closed))
      os << " (judged structure " << num(100.0 * structure_gap_closed, "%.0f") << " %)";
    os << "; no one model carries it to a new run: a level that changes between runs "
          "(temperature, wear, lubrication, a condition that differs by run) or a friction whose "
          "form the model lacks, acting differently at each run's speed and frequency (the factors "
          "are relative to an alpha-model fitted on these runs: that they differ is the finding, "
          "not by how much)";
  } else {
    os << message;
  }
  return os.str();
}

std::string RunLevelsResult::full_report() const {
  std::ostringstream os;
  os << brief_report() << "\n";
  if (!ok) return os.str();
  os << "  RMS over the runs " << num(error_before, "%.4g") << " -> " << num(error_after, "%.4g")
     << "; judged structure " << num(structure_before, "%.4g") << " -> " << num(structure_after, "%.4g")
     << "; sine runs' median error at the fundamental " << num(fundamental_before, "%.4g") << " -> "
     << num(fundamental_after, "%.4g") << "\n";
  for (const RunLevel& r : runs) {
    os << "  " << r.name << ": level x " << num(r.factor, "%.3f") << " +- " << num(r.standard_error, "%.2g")
       << ", RMS " << num(r.rms_before, "%.4g") << " -> " << num(r.rms_after, "%.4g") << "\n";
  }
  return os.str();
}

}  // namespace alphainv
