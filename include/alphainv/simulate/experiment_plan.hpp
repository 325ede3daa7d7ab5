#pragma once
/// \file experiment_plan.hpp
/// The paper's experiment plan (Tables 1 and 2) run on the virtual Omni, and the generator of
/// datasets in the interchange format (`alphainv-dataset/1`) from it. Everything here is in memory:
/// the caller writes the result with write_dataset() (alphainv::data). Not real-time.
///
/// A plan is made from ExperimentPlanOptions: which sine frequencies at which set-point poses,
/// which square waves at which poses, amplitudes, durations, the controller, the plant with its
/// effects, and a seed. The seed decides
///   - each pose's TRUE angles: γ1 = set + U(pose_offsets.gamma1…), γ2 = set + U(…gamma2…), drawn
///     from a hash of (seed, set pose), so a pose's true angles do not depend on which other poses
///     are in the plan (the paper's arms sagged under gravity and P control: Table 3);
///   - each run's measurement-noise seed, from a hash of (seed, kind, set pose, frequency).
/// The dataset records the true (measured) pose in gamma1_deg/gamma2_deg, as the format asks, and
/// the set point in gamma1_set_deg/gamma2_set_deg.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "alphainv/model/controller.hpp"
#include "alphainv/data/dataset.hpp"
#include "alphainv/simulate/invented_effects.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv {

/// A set-point pose of the other two joints [deg].
struct PoseSetPoint {
  double gamma1_deg = 0.0;
  double gamma2_deg = 0.0;
};

/// Range of (true − set) pose angle [deg], drawn uniformly per pose. Defaults: the spread of the
/// paper's Table 3 (γ1 true = set − 3.5…5.5°, γ2 true = set − 0.5…3.6°).
struct PoseOffsetRange {
  double gamma1_min_deg = -5.5;
  double gamma1_max_deg = -3.5;
  double gamma2_min_deg = -3.6;
  double gamma2_max_deg = -0.5;
};

/// The sine frequencies of Table 1 [Hz].
std::vector<double> paper_sine_frequencies_hz();
/// Table 1's 9 poses: γ1 ∈ {25, 45, 65}° × γ2 ∈ {70, 90, 115}°.
std::vector<PoseSetPoint> paper_sine_poses();
/// Table 2's 25 poses: γ1 ∈ {25, 35, 45, 55, 65}° × γ2 ∈ {60, 70, 90, 110, 115}°.
std::vector<PoseSetPoint> paper_square_poses();

/// Known external disturbance pulses d(t) [command unit] (plant_input.hpp) on every run, recorded as
/// its `disturbance_v` column, so the known-input path is tested on ground truth: rectangular
/// pulses of ±amplitude_v (alternating in sign, + first), width_s long, one every period_s from
/// first_s plus a per-run shift frac(0.618·i)·period_s (run i), so they fall at other phases of
/// the reference in each run. amplitude_v = 0: none (no column).
struct DisturbancePulses {
  double amplitude_v = 0.0;  ///< pulse height [command unit], ≥ 0 (0: off)
  double width_s = 0.1;      ///< pulse length [s], 0 < width_s < period_s
  double period_s = 1.0;     ///< one pulse every period_s [s]
  double first_s = 0.5;      ///< start of the first pulse before the per-run shift [s], ≥ 0

  bool active() const noexcept { return amplitude_v > 0.0; }
  /// d(t) of run `run_index` at time `t_s` [s] from the run's start. Real-time safe.
  double at(double t_s, std::size_t run_index) const noexcept;
};

/// What to generate. Default-constructed: the paper's plan (Tables 1 and 2, ±0.07 rad, kp = 2,
/// 1 kHz) on the virtual Omni with every effect OFF. paper_plan_options() adds the bundled set's
/// effects.
struct ExperimentPlanOptions {
  std::uint64_t seed = 1;  ///< decides the true poses and the noise (see the file comment)
  /// The plant. Its pose, initial_theta_rad and measurement.seed are set per run; everything else
  /// (models, effects, quantisation, noise level, tick period = 1/sample rate) is used as given.
  VirtualOmniParams plant;
  Controller controller;  ///< digital PID at the tick (run_closed_loop); default kp = 2 P law

  std::vector<double> sine_freqs_hz = paper_sine_frequencies_hz();  ///< sine frequencies [Hz]
  std::vector<PoseSetPoint> sine_poses = paper_sine_poses();        ///< poses of the sine sweeps
  double sine_amplitude_rad = 0.07;  ///< sine reference amplitude A_r [rad]
  /// Time allowed for the transient [s]. The slowest decay is e^{−C t/2} with C ≈ 2.4…17 1/s over
  /// the paper's poses and α, so 4 s leaves below 1e-3 of it in most runs.
  double sine_settle_s = 4.0;
  /// Steady-state span after the settle time [s], rounded up to whole periods (at least one).
  double sine_steady_s = 2.0;

  std::vector<PoseSetPoint> square_poses = paper_square_poses();  ///< poses of the square waves
  double square_freq_hz = 0.25;        ///< square-wave frequency [Hz] (section 2.4.3)
  double square_amplitude_rad = 0.07;  ///< square-wave amplitude [rad]; runs start at θ = −A (47)
  double square_duration_s = 8.0;      ///< square-wave run length [s] (two periods)

  PoseOffsetRange pose_offsets;       ///< true − set pose angles [deg]
  bool record_truth_columns = false;  ///< add run_closed_loop's truth columns to every run
  DisturbancePulses disturbance_pulses;  ///< known disturbance pulses (off by default)
  /// An invented effect no model knows (invented_effects.hpp), on every run, not recorded
  /// (truth.json says it). Generator-only: off by default.
  InventedEffect invented;
  std::string joint = "yaw";          ///< dataset.json `joint`
  /// Recorded as dataset.json `generator` when not empty (e.g. the omni_gen command line).
  std::string generator_command;

  /// Throws alphainv::Error naming the field ("sine_freqs_hz[3]", "plant.effects.coulomb_v", …).
  void validate() const;
};

/// The bundled dataset's settings (data/omni_yaw_sim): the default plan with a small Coulomb
/// friction Fc = 0.004 V (ε = 1e-3 rad/s; about 2 % of a typical command amplitude of 0.2 V),
/// encoder quantisation 1.5e-4 rad and Gaussian noise σ = 5e-5 rad.
ExperimentPlanOptions paper_plan_options(std::uint64_t seed = 1);

/// One pose of a plan [deg].
struct PlannedPose {
  double gamma1_set_deg = 0.0, gamma2_set_deg = 0.0;  ///< set point
  double gamma1_deg = 0.0, gamma2_deg = 0.0;          ///< true (measured) angles
  double inertia = 0.0;                               ///< I(γ1, γ2) of the plant at the true pose
};

/// One run of a plan.
struct PlannedRun {
  std::string file;                   ///< CSV path relative to the dataset folder
  std::string kind;                   ///< "sine" or "square"
  double freq_hz = 0.0;               ///< reference frequency [Hz]
  double amplitude_rad = 0.0;         ///< reference amplitude [rad]
  double duration_s = 0.0;            ///< run length [s]; samples at 0, T, …, duration_s
  double steady_state_start_s = 0.0;  ///< sine: start of the steady-state window; square: 0
  double initial_theta_rad = 0.0;     ///< θ(0): 0 for sines, −A for squares
  std::size_t pose = 0;               ///< index into ExperimentPlan::poses
  std::uint64_t noise_seed = 0;       ///< the plant's measurement.seed for this run (< 2^53)
};

/// A laid-out plan: distinct poses (sine poses first, in order, then the square-only ones) and runs
/// (all sines, pose-major then frequency, then all squares).
struct ExperimentPlan {
  ExperimentPlanOptions options;
  std::vector<PlannedPose> poses;
  std::vector<PlannedRun> runs;
};

/// Validates `options` and lays out the plan (draws the true poses, names the files).
ExperimentPlan make_experiment_plan(const ExperimentPlanOptions& options);

/// make_experiment_plan(paper_plan_options(seed)): Table 1 (81 sine runs) and Table 2 (25 square
/// runs) with the bundled set's effects.
ExperimentPlan paper_experiment_plan(std::uint64_t seed = 1);

/// The plant parameters of run `i` (the plan's plant at the run's true pose, initial θ, noise
/// seed).
VirtualOmniParams planned_plant(const ExperimentPlan& plan, std::size_t i);

/// Simulates run `i` of `plan` (a fresh VirtualOmni, run_closed_loop). Deterministic.
RunData simulate_planned_run(const ExperimentPlan& plan, std::size_t i);

/// dataset.json for `plan`: format fields, joint, rad/V, sample_rate_hz = 1/T, the controller,
/// `source` ("alphainv virtual Omni, seed N"), `generator` (when set), `truth` (truth_json), and the
/// runs with kind, freq_hz, amplitude_rad, gamma1_deg/gamma2_deg (the true pose) and, per run,
/// gamma1_set_deg, gamma2_set_deg, duration_s, steady_state_start_s and `truth` {inertia,
/// c_at_alpha (C at the α-model's breakpoints), beta_tilde_at_beta_alpha, initial_theta_rad,
/// noise_seed}.
Dataset plan_dataset_index(const ExperimentPlan& plan);

/// The `truth` object of dataset.json as JSON text: every plant parameter and effect, the
/// measurement model, the α filter, the controller implementation and the pose-offset range.
std::string truth_json(const ExperimentPlan& plan);

/// A generated dataset, ready for write_dataset(dir, index, runs).
struct GeneratedDataset {
  Dataset index;
  std::vector<RunData> runs;  ///< runs[i] is the data of index.runs[i]
};

/// Simulates every run of `plan`. Deterministic: the same plan gives bit-identical data.
GeneratedDataset generate_dataset(const ExperimentPlan& plan);

}  // namespace alphainv
