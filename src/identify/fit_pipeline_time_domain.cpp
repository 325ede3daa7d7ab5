// fit_dataset(), stage 7 (fit_stages.hpp): output-error identification of poses that have no
// sine runs.
#include <cmath>
#include <limits>
#include <string>

#include "alphainv/identify/fit_stages.hpp"
#include "alphainv/identify/time_domain_fit.hpp"
#include "alphainv/simulate/known_inputs.hpp"
#include "fit_pipeline_internal.hpp"

namespace alphainv {

void fit_time_domain_poses(const Dataset& dataset, const std::vector<RunData>& data,
                           const FitPipelineOptions& options, DatasetFit& fit) {
  detail::ProgressReporter progress(options);
  progress("time-domain fit", 0, 1);
  TimeDomainFitOptions to;
  to.n_breakpoints = options.n_breakpoints;
  to.threads = options.threads;
  to.simulation = fit.simulation;
  to.effects = fit.effects;  // known effects, kept fixed
  std::vector<TimeDomainRun> all_runs;
  std::size_t torque_off = 0, not_p = 0, open_loop = 0;
  for (std::size_t p = 0; p < fit.poses.size(); ++p) {
    PoseFit& pose = fit.poses[p];
    // With an inertia model every pose with known angles has its model (24)-(25) already.
    if (pose.linear.valid || (fit.has_inertia_model && pose.gamma1_deg)) continue;
    std::vector<TimeDomainRun> runs;
    for (std::size_t i : pose.runs) {
      // A run that switches the motor off is fitted with its torque_enable column as a known
      // input (plant_input.hpp: the amplifier gives nothing while it is 0).
      if (KnownInputSeries::of_run(data[i]).has_torque_off()) ++torque_off;
      const Controller& ctl = dataset.runs[i].controller;
      if (is_open_loop(ctl)) {
        ++open_loop;  // no controller: the recorded v is the input (simulate_open_loop)
      } else if (!(ctl.kp > 0.0)) {
        ++not_p;
        continue;
      }
      runs.push_back({&data[i], ctl});
    }
    if (runs.empty()) continue;
    const TimeDomainLinearFit lin = fit_linear_time_domain(runs, to);
    if (!lin.ok) {
      fit.notes.push_back("pose " + std::to_string(p + 1) +
                          ": time-domain linear fit failed: " + lin.message);
      continue;
    }
    pose.linear.c_linear = lin.c_linear;
    pose.linear.beta_tilde_linear = lin.beta_tilde_linear;
    pose.linear.beta_linear = std::numeric_limits<double>::quiet_NaN();  // kp differs per run
    pose.linear.rms_residual = lin.rms;
    pose.linear.n_points = runs.size();
    pose.linear.valid = true;
    pose.linear.message = "output error on " + std::to_string(runs.size()) +
                          " run(s): C = " + std::to_string(lin.c_linear) + " ± " +
                          std::to_string(lin.c_se) + " 1/s, β̃ = " +
                          std::to_string(lin.beta_tilde_linear) + " ± " +
                          std::to_string(lin.beta_tilde_se) + "; equation-error start C = " +
                          std::to_string(lin.c_equation_error) + ", β̃ = " +
                          std::to_string(lin.beta_tilde_equation_error);
    pose.linear_source = "time domain (output error)";
    all_runs.insert(all_runs.end(), runs.begin(), runs.end());
    if (!fit.alpha.ok && fit.poses.size() == 1) {
      const TimeDomainAlphaFit al = fit_alpha_time_domain(runs, lin, to);
      if (al.ok) {
        fit.alpha.ok = true;
        fit.alpha.model = al.model;
        fit.alpha.message = al.message;
        for (std::size_t k = 0; k < al.model.n_breakpoints; ++k) {
          // C_n1 = 1/C_n (I = 1): se(C_n1) = se(C_n)/C_n².
          const double c = 1.0 / al.model.c_n1[k];
          fit.alpha.c_n1_se[k] = al.c_se[k] / (c * c);
        }
        for (std::size_t k = 0; k < 2; ++k) {
          const double b = 1.0 / al.model.beta_n1[k];
          fit.alpha.beta_n1_se[k] = al.beta_tilde_se[k] / (b * b);
        }
        // What the data say: breakpoints at quantiles of the commands' α lie inside the data
        // (pinned); a coefficient is identifiable by its SE and correlations (TimeDomainAlphaFit).
        // No local points: the sine branch's relative errors on them were not measured.
        fit.alpha.alpha_data_min = 0.0;
        fit.alpha.alpha_data_max = al.alpha_max;
        for (std::size_t k = 0; k < al.model.n_breakpoints; ++k) {
          fit.alpha.breakpoint_identifiable[k] = k > 0 && al.model.alpha[k] <= al.alpha_max;
          fit.alpha.c_n1_identifiable[k] = al.c_identifiable[k];
        }
        fit.alpha.beta_n1_identifiable = al.beta_tilde_identifiable;
        fit.alpha.c_rms_relative = fit.alpha.beta_rms_relative =
            std::numeric_limits<double>::quiet_NaN();
        fit.alpha_source = "time domain (output error)";
        fit.notes.push_back(
            "α-model by output error: breakpoints at quantiles (0, then 50 % … 95 %) of the α of "
            "the commands (largest α in the data " + std::to_string(al.alpha_max) +
            "); RMS of θ − θ_sim " + std::to_string(al.rms) + " against " +
            std::to_string(lin.rms) + " for the linear model");
      } else {
        fit.notes.push_back("time-domain α-model fit failed: " + al.message);
      }
    }
  }
  if (torque_off > 0) {
    fit.notes.push_back(std::to_string(torque_off) +
                        " run(s) switch the motor off (torque_enable = 0: free motion); their "
                        "torque_enable column enters the plant as a known input (the amplifier "
                        "gives nothing while it is 0)");
  }
  if (not_p > 0) {
    fit.notes.push_back(std::to_string(not_p) + " run(s) have kp = 0 but ki or kd != 0; not fitted");
  }
  if (open_loop > 0) {
    fit.notes.push_back(std::to_string(open_loop) +
                        " run(s) have no controller (kp = ki = kd = 0): fitted open loop, the "
                        "recorded command v the input of θ̈ + C·θ̇ = β̃·u");
  }
  if (!all_runs.empty()) {
    fit.notes.push_back(
        std::string("poses without sine runs were identified in the time domain (output error: "
                    "closed-loop simulation of θ under each run's controller, ") +
        (fit.simulation.loop_period_s > 0.0
             ? "as the digital loop at " + std::to_string(1.0 / fit.simulation.loop_period_s) + " Hz"
             : std::string("with the continuous law (43)")) +
        ", fitted to the measured θ by Levenberg-Marquardt)");
    if (fit.poses.size() > 1 && !fit.alpha.ok) {
      fit.notes.push_back("the time-domain α-model is fitted for single-pose datasets only");
    }
  }
  progress("time-domain fit", 1, 1);
}

}  // namespace alphainv
