#pragma once
/// \file known_inputs.hpp
/// The known inputs of a recorded run as the plant sees them over time (plant_input.hpp): the
/// `disturbance_v` column d(t) [command unit], the `torque_enable` column e(t) [0/1] and the
/// `v_comp` column c(t) [command unit, the compensation omni_ctl added to the P law] of
/// docs/dataset-format.md, each held from one sample to the next (zero-order hold, as a recorder
/// samples a signal that is held over each tick). A non-owning view: the columns must outlive it.

#include <cstddef>
#include <vector>

#include "alphainv/data/dataset.hpp"
#include "alphainv/model/plant_input.hpp"

namespace alphainv {

/// Sampled known inputs (file comment). Default-constructed: none (d = 0, the motor on).
class KnownInputSeries {
 public:
  KnownInputSeries() = default;
  /// A view of the columns: sample times `t_s` [s] (strictly increasing), d(t_k), e(t_k)
  /// (e > 0.5 is on) and c(t_k). Any column may be nullptr (not known). Throws alphainv::Error
  /// (field "disturbance_v", "torque_enable" or "v_comp") when a column's length differs from
  /// t_s's.
  KnownInputSeries(const std::vector<double>* t_s, const std::vector<double>* disturbance_v,
                   const std::vector<double>* torque_enable,
                   const std::vector<double>* command_offset_v = nullptr);

  /// The run's `disturbance_v`, `torque_enable` and `v_comp` columns, those it has (none:
  /// empty()).
  static KnownInputSeries of_run(const RunData& run);

  /// No known input: every instant is {0, on, 0}.
  bool empty() const noexcept {
    return disturbance_v_ == nullptr && torque_enable_ == nullptr && command_offset_v_ == nullptr;
  }
  bool has_disturbance() const noexcept { return disturbance_v_ != nullptr; }
  bool has_torque_enable() const noexcept { return torque_enable_ != nullptr; }
  /// Whether the controller's command had a known addition (a `v_comp` column).
  bool has_command_offset() const noexcept { return command_offset_v_ != nullptr; }
  /// Whether the motor is off at some sample.
  bool has_torque_off() const noexcept;

  /// The inputs of sample k (k past the end: the last sample's). Real-time safe.
  KnownInputs at_sample(std::size_t k) const noexcept;
  /// The inputs at time `t_s`: those of the last sample at or before t_s (before the first sample:
  /// the first's). O(log n). Real-time safe.
  KnownInputs at(double t_s) const noexcept;

 private:
  const std::vector<double>* t_ = nullptr;
  const std::vector<double>* disturbance_v_ = nullptr;
  const std::vector<double>* torque_enable_ = nullptr;
  const std::vector<double>* command_offset_v_ = nullptr;
};

}  // namespace alphainv
