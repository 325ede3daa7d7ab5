#pragma once
/// \file recorded_run.hpp
/// A recorded run simulated with a model: under the run's controller, driven by its measured
/// reference r (SampledReference), from its measured initial state, with its known inputs
/// (`disturbance_v`, `torque_enable`: known_inputs.hpp) entering the plant, at its own sample
/// times. What output-error fits, the fit's validation, diagnose and `omni_fit validate` compare
/// with the measurement. Not real-time (allocates the result).

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/controller.hpp"
#include "alphainv/simulate/simulate.hpp"

namespace alphainv {

/// The initial state of a measured run: θ_0, and θ̇ at t0 from a least-squares quadratic through
/// the samples of the first 10 ms (at least 4 samples).
InitialState initial_state_of(const RunData& run);

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
