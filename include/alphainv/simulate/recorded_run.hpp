#pragma once
/// \file recorded_run.hpp
/// A recorded run simulated with a model: under the run's controller, driven by its measured
/// reference r (SampledReference), from its measured initial state, with its known inputs
/// (`disturbance_v`, `torque_enable`: known_inputs.hpp) entering the plant, at its own sample
/// times. What output-error fits, the fit's validation, diagnose and `omni_fit validate` compare
/// with the measurement. Not real-time (allocates the result).

#include <limits>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/controller.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// The initial state of a measured run: θ_0, and θ̇ at t0 from a least-squares quadratic through
/// the samples of the first 10 ms (at least 4 samples).
InitialState initial_state_of(const RunData& run);

/// The measured state at the first sample of a run that is a window cut from a longer record
/// (diagnose's fit windows and folds), from the samples on both sides of it: a one-sided fit
/// through a window's first 10 ms (initial_state_of()) has 11× the noise in θ̇ of a centred one
/// over ±20 ms, and an error of θ̇ at the start rings on in a lightly damped loop. NaN: not known.
struct MeasuredStart {
  double theta_rad = std::numeric_limits<double>::quiet_NaN();
  double theta_dot_rad_s = std::numeric_limits<double>::quiet_NaN();
};

/// MeasuredStart at sample k of `run`: θ and θ̇ at t[k] from a least-squares quartic in t − t[k]
/// over the samples within ±half_span_s (the cubic and quartic terms keep a sine's θ̇ and θ
/// nearly unbiased: 6e-4 rad/s and 2e-6 rad at 7 Hz, 0.01 rad amplitude, ±20 ms); NaN when
/// either side has fewer than half of half_span_s of samples or the fit fails.
MeasuredStart measured_state_at(const RunData& run, std::size_t k, double half_span_s = 0.02);

/// initial_state_of(run) with `start`'s values where they are finite, and the command history.
InitialState initial_state_of(const RunData& run, const MeasuredStart& start,
                              std::vector<double> command_history);

/// Whether the run's known inputs enter the simulation.
enum class KnownInputUse {
  kUse,     ///< the run's disturbance_v and torque_enable columns (those it has)
  kIgnore,  ///< none: d = 0, the motor on (to measure what the columns explain)
};

/// Simulates `run` (file comment) with `model` under `controller` from `initial` (usually
/// initial_state_of(run), with a command history when known). With no controller
/// (is_open_loop(): kp = ki = kd = 0) the run is open loop: its recorded v drives the plant
/// (simulate_open_loop). Never throws: the result says.
SimulationResult simulate_recorded_run(const JointModelAtPose& model, const Controller& controller,
                                       const RunData& run, const InitialState& initial,
                                       const SimulationOptions& options,
                                       KnownInputUse known_inputs = KnownInputUse::kUse);

}  // namespace alphainv
