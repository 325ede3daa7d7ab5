#include "alphainv/simulate/known_inputs.hpp"

#include <algorithm>
#include <string>

#include "alphainv/error.hpp"

namespace alphainv {

KnownInputSeries::KnownInputSeries(const std::vector<double>* t_s,
                                   const std::vector<double>* disturbance_v,
                                   const std::vector<double>* torque_enable,
                                   const std::vector<double>* command_offset_v)
    : t_(t_s),
      disturbance_v_(disturbance_v),
      torque_enable_(torque_enable),
      command_offset_v_(command_offset_v) {
  const std::size_t n = t_ != nullptr ? t_->size() : 0;
  auto check = [n](const std::vector<double>* col, const char* field) {
    if (col != nullptr && col->size() != n) {
      throw Error("expected " + std::to_string(n) + " samples (as the time column), got " +
                      std::to_string(col->size()),
                  {}, 0, field);
    }
  };
  check(disturbance_v_, "disturbance_v");
  check(torque_enable_, "torque_enable");
  check(command_offset_v_, "v_comp");
  if (n == 0) disturbance_v_ = torque_enable_ = command_offset_v_ = nullptr;
}

KnownInputSeries KnownInputSeries::of_run(const RunData& run) {
  return KnownInputSeries(&run.t, run.column("disturbance_v"), run.column("torque_enable"),
                          run.column("v_comp"));
}

bool KnownInputSeries::has_torque_off() const noexcept {
  if (torque_enable_ == nullptr) return false;
  return std::any_of(torque_enable_->begin(), torque_enable_->end(),
                     [](double e) { return !(e > 0.5); });
}

KnownInputs KnownInputSeries::at_sample(std::size_t k) const noexcept {
  KnownInputs in;
  if (empty()) return in;
  k = std::min(k, t_->size() - 1);
  if (disturbance_v_ != nullptr) in.disturbance_v = (*disturbance_v_)[k];
  if (torque_enable_ != nullptr) in.torque_enabled = (*torque_enable_)[k] > 0.5;
  if (command_offset_v_ != nullptr) in.command_offset_v = (*command_offset_v_)[k];
  return in;
}

KnownInputs KnownInputSeries::at(double t_s) const noexcept {
  if (empty()) return {};
  const auto it = std::upper_bound(t_->begin(), t_->end(), t_s);
  const std::size_t k = it == t_->begin() ? 0 : static_cast<std::size_t>(it - t_->begin()) - 1;
  return at_sample(k);
}

}  // namespace alphainv
