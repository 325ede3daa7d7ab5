// omni_fit demo: the paper's alpha-invariant and linear models at one pose, simulated on the
// paper's experiment plan (Table 1's sine sweep, a 0.25 Hz square wave).
#include "demo_command.hpp"

#include <cstdio>
#include <vector>

#include "alphainv/identify/local_linear.hpp"
#include "alphainv/identify/metrics.hpp"
#include "alphainv/model/alpha.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/simulate.hpp"
#include "apps/common/exit_code.hpp"

namespace omni_fit {

CLI::App* add_demo_subcommand(CLI::App& app, DemoCommandOptions& o) {
  CLI::App* demo =
      app.add_subcommand("demo", "simulate the paper's model on the paper's experiment plan");
  demo->add_option("--gamma1", o.gamma1_deg, "pose angle gamma1 [deg]")->capture_default_str();
  demo->add_option("--gamma2", o.gamma2_deg, "pose angle gamma2 [deg]")->capture_default_str();
  demo->add_option("--amplitude", o.amplitude_rad, "reference amplitude [rad]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  demo->add_option("--kp", o.kp, "proportional gain [V/rad]")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  demo->add_flag("--cvode", o.cvode,
                 "integrate with SUNDIALS CVODE instead of the fixed-point scheme");
  return demo;
}

int run_demo(const DemoCommandOptions& o) {
  using namespace alphainv;
  const double gamma1_deg = o.gamma1_deg, gamma2_deg = o.gamma2_deg;
  const double amplitude_rad = o.amplitude_rad, kp = o.kp;
  const bool cvode = o.cvode;
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
      return apps::exit_status(apps::ExitCode::kFailed);
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
  return apps::exit_status(apps::ExitCode::kOk);
}


}  // namespace omni_fit
