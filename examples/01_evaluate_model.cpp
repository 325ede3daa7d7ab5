// 01: evaluate the α-invariant model at 1 kHz, as a haptic app's control tick would.
// Links only alphainv::core (header-only, Eigen). Prints α̂, C and β̃ for a 3 Hz command.
#include <cmath>
#include <cstdio>

#include <alphainv/model/damping_model.hpp>
#include <alphainv/model/inertia_model.hpp>
#include <alphainv/rt/alpha_estimator.hpp>

int main() {
  const alphainv::InertiaModel inertia = alphainv::paper_inertia_model();
  const alphainv::AlphaModel model = alphainv::paper_alpha_model();
  alphainv::rt::AlphaEstimator estimator;  // configure once, outside the loop (1 kHz, 25 Hz cut-off)
  estimator.reset();

  const double gamma1 = alphainv::deg_to_rad(60.08), gamma2 = alphainv::deg_to_rad(87.00);
  const double amplitude_v = 0.1, freq_hz = 3.0, pi = 3.14159265358979323846;
  for (int tick = 0; tick < 1000; ++tick) {  // one second at 1 kHz
    const double t_s = tick * 1e-3;
    const double command_v = amplitude_v * std::sin(2 * pi * freq_hz * t_s);
    // --- real-time part: no allocation, no locks, no I/O ---
    const alphainv::rt::AlphaEstimate est = estimator.update(command_v);
    const double i = inertia.inertia(gamma1, gamma2);
    const double c = model.damping(est.alpha, i);
    const double beta_tilde = model.beta_tilde(est.alpha, i);
    // ---
    if (tick % 200 == 199) {
      std::printf("t=%.3f s  alpha=%.4f (sine: %.4f)  C=%.3f 1/s  beta~=%.2f\n", t_s, est.alpha,
                  std::pow(amplitude_v * 2 * pi * freq_hz, 2), c, beta_tilde);
    }
  }
  return 0;
}
