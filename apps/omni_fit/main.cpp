// omni_fit: offline identification, simulation and diagnosis for the α-invariant model.
// Subcommands: fit (fit_command.cpp), simulate (simulate_command.cpp), diagnose
// (diagnose_command.cpp), sweep (sweep_command.cpp) and demo (the paper's model on its plan).
#include <cmath>
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "alphainv/model/alpha.hpp"
#include "alphainv/identify/local_linear.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/simulate/simulate.hpp"
#include "diagnose_command.hpp"
#include "fit_command.hpp"
#include "sweep_command.hpp"
#include "simulate_command.hpp"

namespace {

using namespace alphainv;

int run_demo(double gamma1_deg, double gamma2_deg, double amplitude_rad, double kp, bool cvode) {
  JointModelAtPose model = model_at_pose(paper_linear_model(), paper_alpha_model(),
                                         deg_to_rad(gamma1_deg), deg_to_rad(gamma2_deg));
  Controller ctl;
  ctl.kp = kp;
  SimulationOptions opt;
  opt.integrator = cvode ? Integrator::kCvode : Integrator::kFixedPointRk4;

  std::printf("# alphainv demo: the paper's alpha-invariant and linear models at gamma1=%.2f deg, "
              "gamma2=%.2f deg\n", gamma1_deg, gamma2_deg);
  std::printf("I = %.6f   C_linear = %.3f 1/s   beta~_linear = %.2f   integrator = %s\n\n",
              model.inertia, model.c_linear, model.beta_tilde_linear,
              cvode ? "CVODE" : "fixed point (44)-(46) + RK4");
  std::printf("Sine sweep, +-%.3f rad (Table 1 frequencies): fundamental of theta/r\n", amplitude_rad);
  std::printf("%8s %10s %10s %10s %10s %10s %8s\n", "f [Hz]", "alpha", "gain_a", "phase_a",
              "gain_lin", "phase_lin", "iters");
  for (double f : {1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0}) {
    const SineReference ref(amplitude_rad, f);
    const auto times = uniform_times(6.0, 1e-3);
    model.use_alpha = true;
    const SimulationResult a = simulate(model, ctl, ref, times, {}, opt);
    model.use_alpha = false;
    const SimulationResult l = simulate(model, ctl, ref, times, {}, opt);
    if (!a.ok || !l.ok) {
      std::fprintf(stderr, "omni_fit demo: simulation failed at %.1f Hz: %s%s\n", f,
                   a.message.c_str(), l.message.c_str());
      return 3;
    }
    std::vector<double> r(times.size());
    for (std::size_t k = 0; k < times.size(); ++k) r[k] = ref.at(times[k]).r;
    const IndexRange win = steady_state_window(times, f, 3.0);
    const FundamentalError e = fundamental_error(times, r, a.theta, l.theta, f, win.begin, win.end);
    const SineFit fa = fit_sine(times.data() + win.begin, a.theta.data() + win.begin, win.size(),
                                2 * kPi * f);
    const double alpha36 = alpha_sine_steady_state(kp, 2 * kPi * f, fa.a1, fa.a2, amplitude_rad);
    std::printf("%8.1f %10.3f %10.4f %10.2f %10.4f %10.2f %8.2f\n", f, alpha36, e.gain_measured,
                e.phase_measured_deg, e.gain_simulated, e.phase_simulated_deg, a.mean_iterations());
  }
  const SquareReference sq(amplitude_rad, 0.25);
  const auto times = uniform_times(4.0, 1e-3);
  model.use_alpha = true;
  const SimulationResult a = simulate(model, ctl, sq, times, {-amplitude_rad, 0, 0}, opt);
  model.use_alpha = false;
  const SimulationResult l = simulate(model, ctl, sq, times, {-amplitude_rad, 0, 0}, opt);
  const AbsErrorStats s = abs_error_stats(a.theta, l.theta, 0, times.size());
  std::printf("\nSquare wave 0.25 Hz, 4 s: |theta_linear - theta_alpha| median %.4f rad, "
              "90th percentile %.4f rad\n", s.median, s.p90);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"omni_fit: identify and simulate alpha-invariant joint models"};
  app.require_subcommand(1);
  auto* demo = app.add_subcommand("demo", "simulate the paper's model on the paper's experiment plan");
  double g1 = 60.08, g2 = 87.00, amp = 0.07, kp = 2.0;
  bool cvode = false;
  demo->add_option("--gamma1", g1, "pose angle gamma1 [deg]")->capture_default_str();
  demo->add_option("--gamma2", g2, "pose angle gamma2 [deg]")->capture_default_str();
  demo->add_option("--amplitude", amp, "reference amplitude [rad]")->capture_default_str()
      ->check(CLI::PositiveNumber);
  demo->add_option("--kp", kp, "proportional gain [V/rad]")->capture_default_str()
      ->check(CLI::PositiveNumber);
  demo->add_flag("--cvode", cvode, "integrate with SUNDIALS CVODE instead of the fixed-point scheme");
  auto* fitc = app.add_subcommand("fit", "identify the linear, inertia and alpha-invariant models of a dataset");
  omni_fit::FitCommandOptions fo;
  fitc->add_option("dataset", fo.dataset_dir, "dataset folder (alphainv-dataset/1)")->required();
  fitc->add_option("-o,--out", fo.out_dir, "output folder for model.json and report.md")->required();
  fitc->add_flag("--json", fo.json, "print one JSON object with the headline figures to stdout");
  fitc->add_flag("-q,--quiet", fo.quiet, "print nothing but errors");
  fitc->add_flag("--no-plots", fo.no_plots, "skip the report's figures (gnuplot)");
  fitc->add_option("--threads", fo.threads, "threads for the validation runs (default: all cores)");
  fitc->add_option("--breakpoints", fo.n_breakpoints, "number of alpha breakpoints N (2..8)")
      ->capture_default_str()->check(CLI::Range(2, 8));
  fitc->add_option("--effects-from", fo.effects_from,
                   "fit with the known effects of this model.json (its \"effects\", e.g. from "
                   "`omni_fit diagnose`): the sine points are corrected for them, the simulations "
                   "include them, the written model carries them");
  fitc->add_option("--effect", fo.effect_specs,
                   "a known effect NAME:PARAM=VALUE[,PARAM=VALUE], repeatable, after "
                   "--effects-from; e.g. coulomb_friction:coulomb_v=0.004 (names: " +
                       alphainv::effect_names_text() + "; parameters as in model.json)")
      ->allow_extra_args(false);
  fitc->add_flag("--refine-effects", fo.refine_effects,
                 "refine the known effects' parameters on all runs: each trial a whole fit, "
                 "scored by the alpha-model's squared position error over every simulated run "
                 "(Nelder-Mead, at most 40 fits)");
  fitc->footer("Examples:\n  omni_fit fit data/omni_yaw_sim -o out/fit --json\n"
               "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effect coulomb_friction:coulomb_v=0.004\n"
               "  omni_fit fit run_dir -o out/fit-fx --effects-from out/diag/model.json\n"
               "  omni_fit fit run_dir -o out/fit-fx --effects-from out/diag/model.json --refine-effects\n"
               "Exit codes: 0 ok, 1 usage, 2 bad input (the message names the file or option), 3 "
               "nothing could be fitted.");
  omni_fit::SimulateCommandOptions so;
  CLI::App* simc = omni_fit::add_simulate_subcommand(app, so);
  omni_fit::DiagnoseCommandOptions dgo;
  CLI::App* diagc = omni_fit::add_diagnose_subcommand(app, dgo);
  omni_fit::SweepCommandOptions swo;
  CLI::App* sweepc = omni_fit::add_sweep_subcommand(app, swo);
  app.footer("Examples:\n  omni_fit fit data/omni_yaw_sim -o out/fit --json\n"
             "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effect coulomb_friction:coulomb_v=0.004\n"
             "  omni_fit fit data/omni_yaw_sim -o out/fit-fx --effects-from out/diag/model.json\n"
             "  omni_fit simulate out/fit/model.json --pose 60.08,87 --sine 3Hz -o run.csv\n"
             "  omni_fit diagnose data/omni_yaw_sim -o out/diag --json\n"
             "  omni_fit demo --gamma1 60.08 --gamma2 87 --amplitude 0.07\n"
             "Exit codes: 0 ok, 1 usage, 2 bad input (the message names the file), 3 nothing could be fitted\n"
             "(fit) or the simulation failed (simulate).");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 1;
  }
  if (*demo) return run_demo(g1, g2, amp, kp, cvode);
  if (*fitc) return omni_fit::run_fit(fo);
  if (*simc) return omni_fit::run_simulate(so);
  if (*diagc) return omni_fit::run_diagnose(dgo);
  if (*sweepc) return omni_fit::run_sweep(swo);
  return 0;
}
