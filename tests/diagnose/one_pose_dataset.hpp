#pragma once
// Test helper (not a test): the generated dataset `omni_fit sweep` diagnoses.

#include <cstdint>

#include "alphainv/model/effects.hpp"
#include "alphainv/simulate/experiment_plan.hpp"

namespace alphainv::test {

/// The 10-run dataset of `omni_fit sweep`: the sine sweep and a square wave at one pose (the
/// seed's), with one hidden effect (or none).
inline GeneratedDataset one_pose_dataset(const Effects& hidden, std::uint64_t seed) {
  ExperimentPlanOptions plan = paper_plan_options(seed);
  plan.plant.effects = hidden;
  const auto poses = paper_sine_poses();
  plan.sine_poses = {poses[seed % poses.size()]};
  plan.square_poses = plan.sine_poses;
  return generate_dataset(make_experiment_plan(plan));
}

}  // namespace alphainv::test
