#pragma once
/// \file external_disturbance.hpp
/// A torque that depends on time, not on the state (the catalogue's `external_disturbance`:
/// steps and pulses a person or a load applies), located in time from one run's equation-error
/// torque residual
///     n̂(t) = (θ̈ + C(α, I)·θ̇)/β̃(α, I) − u(t)          (u of plant_input.hpp, measured θ)
/// and reported as a time series d̂(t) [command unit], the form of a run's `disturbance_v` column
/// (docs/dataset-format.md), so that the estimate enters eq. (11) the one way every known
/// disturbance does (plant_input.hpp's d(t)).
///
/// What the state explains first. n̂ is fitted by least squares on the caller's functions of the
/// state (e.g. 1, tanh(θ̇/ε), θ̇, θ, …: friction, offsets, springs and a misfit of C, β̃ that no
/// effect has absorbed yet) and only the remainder is located; the fit is repeated once without
/// the samples of the intervals found, so that pulses do not bend it.
///
/// What the reference explains. When the reference is periodic (reference_period_s), what the
/// model misses along it (an α-model misfit at some α, a cogging the state functions do not
/// hold) repeats each cycle; a disturbance does not. The remainder's median over the cycles at
/// each phase is removed (a median: a pulse at one phase in fewer than half the cycles does not
/// move it). Without it, a cogging + pulses dataset left window means 3-9 times wider in its
/// 1.5-3.5 Hz sine runs than in the 4-7 Hz ones, and their pulses were not located.
///
/// What the position explains. A torque that is a function of θ (a cogging, a position-dependent
/// friction or spring the state functions do not hold) repeats wherever θ does, and a reference's
/// period does not remove it when the joint's path is not periodic (a pulse, a stick or a lightly
/// damped loop makes each cycle's path differ). When the caller passes θ, the remainder's median at
/// each position is removed: θ's range in kPositionBins bins, each bin's samples grouped into
/// passes (a pass ends when θ has been out of the bin for more than window_s/2), the median over
/// the passes of their means (a pulse in fewer than half the passes does not move it). The samples
/// of a bin with fewer than kMinPositionPasses passes are left out of the window means (a torque of
/// position cannot be told there from one of time), not out of an interval's edges and level:
/// active windows of one sign with only such windows between them are one interval, and its edges
/// are sought through such windows next to it (a pulse that pushes the joint where it has not been
/// is located whole). It is removed only where it serves: when at least kMinPositionShare of the
/// valid samples are in repeated bins (a hold the joint is pushed off, a ramp, repeat no position)
/// and it narrows the window means' spread to kPositionSpreadGain of that without it
/// (DisturbanceEstimate::position_part_removed). On a cogging (period 0.02 rad) + pulses dataset
/// the square run, whose hold positions differ from hold to hold, left window means 4-5 times wider
/// than the sine runs' and none of its pulses located; with the position's part removed its three
/// pulses after a hold are (the 2 Hz and 3 Hz runs' wide remainder is a misfit at the reference's
/// fundamental whose size varies from cycle to cycle, not a torque of θ, and stays).
///
/// Located. The remainder is averaged over windows of DisturbanceOptions::window_s; a window whose mean is
/// more than `threshold` robust spreads (1.4826 × the median absolute deviation of the window
/// means) from the run's median window is active. Runs of active windows of one sign are
/// intervals; each interval's edges are refined to the sample by a least-squares step (the
/// split that maximises the cumulative sum of n̂ − baseline − level/2 within a window of the
/// edge), and its level is the mean of n̂ − baseline over it. What the state explains spreads
/// over many windows and raises the spread; a pulse or a step sticks out of it.
/// Time-localised only: when more than `max_active_share` of the windows are active, the
/// residual is not a disturbance of a few time windows and nothing is returned (the reason says
/// so). d̂ is n̂'s pulse part, not a fit to the output error: diagnose checks it by simulating the
/// runs with d̂ as a known disturbance (the error must drop).
///
/// Mirrored half cycles. Under a periodic reference the model's misfit is mirrored in each half
/// cycle (the loop's response to the falling half is the rising half's, negated), and where the
/// periodic part cannot be removed (a start-up transient, fewer than kMinPeriodicCycles cycles)
/// it stands out as intervals of alternating sign half a period apart. Such pairs are set aside,
/// a disturbance does not keep to the reference's half period: an unmodelled 3.4 ms command
/// delay left 9 intervals in the 3-4 Hz runs' first second, each paired so (e.g. 1.15-1.28 s at
/// +0.065 V and 1.32-1.45 s at −0.066 V at 3 Hz), and was named external_disturbance. Pulses
/// that do keep to it (alternating pulses one every 1 s under a 0.5 Hz sine) are set aside too.
/// Offline.

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

namespace alphainv {

/// Settings of locate_disturbance().
struct DisturbanceOptions {
  double window_s = 0.05;        ///< window length of the means [s], > 0
  double threshold = 6.0;        ///< active: |mean − median| > threshold × robust spread
  double max_active_share = 0.3; ///< more active windows than this share: not time-localised
  double min_interval_s = 0.02;  ///< shorter intervals (after refinement) are dropped [s]
  /// Period of the run's reference [s] when it is periodic (a sine, a square wave), else 0: the
  /// remainder's part periodic with it (its median over the cycles at each phase, in bins of
  /// window_s/5) is removed before the windows, when the valid samples span at least
  /// kMinPeriodicCycles cycles (file comment); ≥ 0.
  double reference_period_s = 0.0;
  /// Cycles the valid samples must span for the periodic part to be removed.
  static constexpr double kMinPeriodicCycles = 4.0;
  /// Bins of θ's range (over the valid samples) for the part that is a function of position
  /// (file comment, "What the position explains").
  static constexpr std::size_t kPositionBins = 200;
  /// Passes a position bin needs for its median to be removed.
  static constexpr std::size_t kMinPositionPasses = 8;
  /// Share of the valid samples that must lie in repeated bins for the position's part to be
  /// removed.
  static constexpr double kMinPositionShare = 0.5;
  /// The position's part is removed only when the spread with it removed is at most this share
  /// of the spread without.
  static constexpr double kPositionSpreadGain = 0.8;
  /// Two intervals of opposite sign whose centres are half a reference period apart to within
  /// this fraction of it are set aside (file comment, "Mirrored half cycles").
  static constexpr double kHalfPeriodTolerance = 0.2;

  /// Throws alphainv::Error naming the field when a value is out of range.
  void validate() const;
};

/// One interval of a disturbance: d̂ = level_v on [start_s, end_s).
struct DisturbanceInterval {
  double start_s = 0.0;   ///< [s], the run's time axis
  double end_s = 0.0;     ///< [s]
  double level_v = 0.0;   ///< mean of the remainder − baseline over the interval [command unit]
  double spreads = 0.0;   ///< |level| in robust spreads of the window means
};

/// What locate_disturbance() found in one run.
struct DisturbanceEstimate {
  bool ok = false;         ///< usable: enough windows to judge (≥ 10)
  std::string message;     ///< why not usable, or why nothing was located (empty otherwise)
  double baseline_v = std::numeric_limits<double>::quiet_NaN();  ///< median window mean
  double spread_v = std::numeric_limits<double>::quiet_NaN();    ///< robust spread of them
  std::size_t windows = 0, active_windows = 0;
  std::vector<DisturbanceInterval> intervals;  ///< in time order
  /// d̂ at every sample of the input (0 outside the intervals) [command unit].
  std::vector<double> d_v;
  /// RMS of d̂ over the samples [command unit].
  double rms_v = 0.0;
  /// Intervals set aside as mirrored half cycles (file comment); not in `intervals`.
  std::size_t half_period_pairs_set_aside = 0;
  /// Whether the remainder's part that is a function of position was removed (file comment,
  /// "What the position explains").
  bool position_part_removed = false;
};

/// Locates a time-dependent torque in n̂ (file comment). `t_s` strictly increasing, `n_hat_v`
/// of the same length; `valid[k]` false where n̂ is not known (e.g. the ends of the run, where
/// θ̈ is one-sided): those samples are left out of the windows (empty: all valid). Throws
/// alphainv::Error (field "n_hat_v", "valid" or "state_basis[j]") when the lengths differ.
/// `state_basis`: the functions of the state n̂ is fitted on first, each sampled like t_s (empty:
/// none; a constant is always fitted through the baseline). `position_rad`: θ sampled like t_s
/// (empty: no part of position removed); throws alphainv::Error (field "position_rad") when its
/// length differs.
DisturbanceEstimate locate_disturbance(const std::vector<double>& t_s,
                                       const std::vector<double>& n_hat_v,
                                       const std::vector<bool>& valid = {},
                                       const DisturbanceOptions& options = {},
                                       const std::vector<std::vector<double>>& state_basis = {},
                                       const std::vector<double>& position_rad = {});

}  // namespace alphainv
