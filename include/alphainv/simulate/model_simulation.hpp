#pragma once
/// \file model_simulation.hpp
/// Simulating a run with the model of a `model.json` (what `omni_fit simulate` does): the joint
/// model at a pose, a sine or square reference, the model's controller and simulation mode, and the
/// result as a run of the interchange format (dataset.hpp). Set-up code: allocates, throws
/// alphainv::Error naming the field; none of it is real-time safe.

#include <optional>
#include <string>

#include "alphainv/model/controller.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// The joint model of `model` at pose (γ1, γ2) [deg, the measured angles as in dataset.json].
///
/// With an inertia model: I from eq. (6) at the pose, C_linear and β̃_linear from (24)-(25); the
/// pose is then required. Without one: the per-pose linear model (22) of `model.poses` nearest to
/// the pose (Euclidean in degrees, over the poses whose angles are known), or the only pose when
/// there is one; I = 1 (the α-model's C_n1 is then 1/C_n at that pose, as omni_fit fits it).
/// `model.effects` are always copied. `use_alpha` selects the α-model (38)-(42) (it must exist) or
/// the global linear model (26). `note`, when given, receives one line saying which model was used
/// (e.g. "no inertia model: the linear model of the nearest pose, 65/90 deg").
/// Throws alphainv::Error (field "gamma1_deg", "poses" or "alpha_model") when the model cannot
/// give a model at this pose.
JointModelAtPose model_at(const ModelFile& model, std::optional<double> gamma1_deg,
                          std::optional<double> gamma2_deg, bool use_alpha,
                          std::string* note = nullptr);

/// The reference of a simulated run.
enum class ModelRunReference {
  kSine,    ///< r = A sin(2πft), from θ(0) = 0
  kSquare,  ///< r = ±A (SquareReference, +A first), from θ(0) = −A like the paper's step runs
};

/// What to simulate.
struct ModelRunOptions {
  ModelRunReference reference = ModelRunReference::kSine;
  double freq_hz = 3.0;            ///< reference frequency [Hz], > 0
  double amplitude_rad = 0.07;     ///< reference amplitude A [position unit], > 0
  double duration_s = 8.0;         ///< run length [s], > 0; samples at 0, 1/rate, …, duration
  double sample_rate_hz = 1000.0;  ///< output sample rate [Hz], > 0
  std::optional<double> kp;  ///< overrides the model's controller kp [command unit/position unit]
  /// Solver settings; loop_period_s is replaced by the model's (ModelFile::loop_period_s), so the
  /// run uses the digital loop exactly when the model was identified with it.
  SimulationOptions simulation;
  /// Known inputs (plant_input.hpp): a run whose `disturbance_v` and `torque_enable` columns, at
  /// its own sample times and held between them (known_inputs.hpp), enter the plant; the simulated
  /// run records them at its sample times. nullptr: none. Must outlive the call.
  const RunData* known_inputs = nullptr;
};

/// A simulated run.
struct ModelRun {
  bool ok = false;      ///< false: the simulation failed (message says why), `data` is empty
  std::string message;  ///< the solver's message
  /// t [s], r, theta (the simulated θ) [position unit], v [command unit], and the extra columns
  /// "alpha" [command unit²/s²], "C" [1/s], "beta_tilde" [rad/s² per command unit] and
  /// "theta_dot" [position unit/s].
  RunData data;
  RunInfo info;  ///< kind, freq_hz, amplitude_rad, pose, controller; file "runs/<kind>_<f>hz.csv"
  Controller controller;         ///< the controller simulated (the model's, kp overridden)
  SimulationOptions simulation;  ///< the settings used (with the model's loop_period_s)
};

/// Simulates `options` with `joint` (from model_at) under the controller and simulation mode of
/// `model`. Throws alphainv::Error naming the option ("freq_hz", "amplitude_rad", "duration_s",
/// "sample_rate_hz", "kp", or "disturbance_v"/"torque_enable" of known_inputs) when one is out of
/// range; a failed simulation returns ok = false.
/// `gamma1_deg`/`gamma2_deg` go into the RunInfo only.
ModelRun simulate_model_run(const ModelFile& model, const JointModelAtPose& joint,
                            const ModelRunOptions& options,
                            std::optional<double> gamma1_deg = std::nullopt,
                            std::optional<double> gamma2_deg = std::nullopt);

/// A one-run dataset of `run` (position and command units from `model`, sample rate from
/// `sample_rate_hz`), for write_dataset; `omni_fit fit` reads it.
Dataset model_run_dataset(const ModelFile& model, const ModelRun& run, double sample_rate_hz);


}  // namespace alphainv
