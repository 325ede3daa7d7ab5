#pragma once
// Test helper (not a test): the generated dataset `omni_fit sweep` diagnoses.

#include <cstdint>

#include "alphainv/model/effects.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv::test {

/// The 10-run dataset of `omni_fit sweep`: the sine sweep and a square wave at one pose (the
/// seed's), with one hidden effect (or none); `noise_std_rad` < 0: the paper plan's (5e-5 rad).
inline GeneratedDataset one_pose_dataset(const Effects& hidden, std::uint64_t seed,
                                         double noise_std_rad = -1.0) {
  ExperimentPlanOptions plan = paper_plan_options(seed);
  plan.plant.effects = hidden;
  if (noise_std_rad >= 0.0) plan.plant.measurement.noise_std_rad = noise_std_rad;
  const auto poses = paper_sine_poses();
  plan.sine_poses = {poses[seed % poses.size()]};
  plan.square_poses = plan.sine_poses;
  return generate_dataset(make_experiment_plan(plan));
}

}  // namespace alphainv::test
