#pragma once
// Test helper (not a test): the generated dataset `omni_fit sweep` diagnoses.

#include <cstdint>
#include <memory>
#include <vector>

#include "alphainv/diagnose/diagnose.hpp"
#include "alphainv/identify/fit_pipeline.hpp"
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

/// one_pose_dataset() fitted by omni_fit fit's pipeline (without validation) and made diagnose's
/// runs; the runs point into the dataset and the fit (keep this alive while they are used).
struct OnePoseDiagnoseRuns {
  GeneratedDataset dataset;
  DatasetFit fit;
  std::vector<DiagnoseRun> runs;
};

inline std::unique_ptr<OnePoseDiagnoseRuns> one_pose_diagnose_runs(const Effects& hidden, std::uint64_t seed) {
  auto out = std::make_unique<OnePoseDiagnoseRuns>();
  out->dataset = one_pose_dataset(hidden, seed);
  FitPipelineOptions fo;
  fo.run_validation = false;
  out->fit = fit_dataset(out->dataset.index, out->dataset.runs, fo);
  out->runs = diagnose_runs(out->dataset.index, out->dataset.runs, out->fit);
  return out;
}

}  // namespace alphainv::test
