#include "alphainv/device/sim_transport.hpp"

#include <time.h>

#include <cmath>
#include <cstdlib>

#include "alphainv/error.hpp"
#include "drain.hpp"

namespace alphainv::device {
namespace {

long long monotonic_ns() noexcept {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<long long>(t.tv_sec) * 1'000'000'000LL + t.tv_nsec;
}

}  // namespace

const char* to_string(IoStatus status) noexcept {
  switch (status) {
    case IoStatus::kOk:
      return "ok";
    case IoStatus::kNoData:
      return "no data";
    case IoStatus::kCorrupt:
      return "corrupt report";
    case IoStatus::kDisconnected:
      return "disconnected";
  }
  return "unknown";
}

const char* to_string(SimFaultKind kind) noexcept {
  switch (kind) {
    case SimFaultKind::kNone:
      return "none";
    case SimFaultKind::kDisconnect:
      return "disconnect";
    case SimFaultKind::kStall:
      return "stall";
    case SimFaultKind::kCorrupt:
      return "corrupt";
    case SimFaultKind::kOutOfSequence:
      return "sequence";
    case SimFaultKind::kEncoderJump:
      return "encoder-jump";
    case SimFaultKind::kSlow:
      return "slow";
  }
  return "unknown";
}

SimFault parse_sim_fault(const std::string& text, const std::string& field) {
  const auto at = text.find('@');
  const std::string expected =
      "expected KIND@SECONDS with KIND one of disconnect, stall, corrupt, sequence, encoder-jump, "
      "slow, got '" +
      text + "'";
  if (at == std::string::npos) throw Error(expected, {}, 0, field);
  const std::string kind = text.substr(0, at);
  std::string secs = text.substr(at + 1);
  if (!secs.empty() && secs.back() == 's') secs.pop_back();
  SimFault f;
  const SimFaultKind kinds[] = {SimFaultKind::kDisconnect,  SimFaultKind::kStall,
                                SimFaultKind::kCorrupt,     SimFaultKind::kOutOfSequence,
                                SimFaultKind::kEncoderJump, SimFaultKind::kSlow};
  bool found = false;
  for (SimFaultKind k : kinds) {
    if (kind == to_string(k)) {
      f.kind = k;
      found = true;
    }
  }
  if (!found) throw Error(expected, {}, 0, field);
  char* end = nullptr;
  f.at_s = std::strtod(secs.c_str(), &end);
  if (secs.empty() || end != secs.c_str() + secs.size() || !std::isfinite(f.at_s) || f.at_s < 0.0) {
    throw Error(expected, {}, 0, field);
  }
  return f;
}

VirtualDevice::VirtualDevice(const VirtualOmniParams& params, const ReportScaling& scaling,
                             SimFault fault, std::size_t log_capacity)
    : plant_(params), scaling_(scaling), fault_(fault), log_(log_capacity == 0 ? 1 : log_capacity) {
  queue_report();
}

bool VirtualDevice::fault_active() const noexcept {
  return fault_.kind != SimFaultKind::kNone &&
         plant_.time_s() >= fault_.at_s - 0.5 * plant_.params().tick_period_s;
}

void VirtualDevice::queue_report() noexcept {
  const bool active = fault_active();
  if (active && fault_tick_ < 0) fault_tick_ = plant_.ticks();
  if (active && fault_.kind == SimFaultKind::kStall) return;
  InputReport in;
  in.sequence = sequence_++;
  if (active && fault_.kind == SimFaultKind::kOutOfSequence) {
    in.sequence = static_cast<std::uint16_t>(in.sequence - 5);
  }
  double theta = plant_.theta_measured();
  if (active && fault_.kind == SimFaultKind::kEncoderJump) theta += 0.5;
  in.encoder_counts[0] = scaling_.counts(0, theta);
  in.encoder_counts[1] = scaling_.counts(1, deg_to_rad(plant_.params().gamma1_deg));
  in.encoder_counts[2] = scaling_.counts(2, deg_to_rad(plant_.params().gamma2_deg));
  in.status = kStatusMotorEnabled;
  if (watchdog_report_) {
    in.status = static_cast<std::uint16_t>(in.status | kStatusWatchdog);
    watchdog_report_ = false;
  }
  if (queue_size_ == kQueue) {  // the oldest report is lost, as in a full kernel buffer
    queue_head_ = (queue_head_ + 1) % kQueue;
    --queue_size_;
  }
  auto& slot = queue_[(queue_head_ + queue_size_) % kQueue];
  encode(in, slot.data());
  if (active && fault_.kind == SimFaultKind::kCorrupt) slot[17] ^= 0x5A;
  ++queue_size_;
}

int VirtualDevice::write(const std::uint8_t* data, std::size_t len) noexcept {
  WrittenCommand& entry = log_[log_count_ % log_.size()];
  ++log_count_;
  entry = WrittenCommand{};
  entry.device_tick = plant_.ticks();
  entry.fault_active = fault_active();
  entry.decoded = decode(data, len, entry.report) == DecodeStatus::kOk;
  if (!entry.decoded) entry.report = OutputReport{};
  if (entry.fault_active && fault_.kind == SimFaultKind::kDisconnect) return -1;
  entry.delivered = true;
  if (entry.decoded) {
    const long long now = monotonic_ns();
    if (last_valid_ns_ >= 0 && static_cast<double>(now - last_valid_ns_) > watchdog_s_ * 1e9) {
      ++watchdog_trips_;
      watchdog_report_ = true;
    }
    last_valid_ns_ = now;
  }
  const double v = entry.report.enable ? scaling_.command_v(entry.report.dac_counts) : 0.0;
  if (entry.decoded) last_v_ = v;
  plant_.step(v, push_.next(plant_.time_s(), plant_.theta(), plant_.theta_dot()));
  queue_report();
  return static_cast<int>(len);
}

int VirtualDevice::read(std::uint8_t* buf, std::size_t len) noexcept {
  if (fault_active() && fault_.kind == SimFaultKind::kDisconnect) return -1;
  if (queue_size_ == 0) return 0;
  const auto& slot = queue_[queue_head_];
  queue_head_ = (queue_head_ + 1) % kQueue;
  --queue_size_;
  const std::size_t n = len < kInputReportSize ? len : kInputReportSize;
  for (std::size_t i = 0; i < n; ++i) buf[i] = slot[i];
  return static_cast<int>(n);
}

bool VirtualDevice::watchdog_tripped() const noexcept {
  return last_valid_ns_ >= 0 &&
         static_cast<double>(monotonic_ns() - last_valid_ns_) > watchdog_s_ * 1e9;
}

double VirtualDevice::applied_command_v() const noexcept {
  return watchdog_tripped() ? 0.0 : last_v_;
}

std::vector<WrittenCommand> VirtualDevice::written() const {
  std::vector<WrittenCommand> out;
  const std::size_t n = log_count_ < log_.size() ? log_count_ : log_.size();
  for (std::size_t i = log_count_ - n; i < log_count_; ++i) out.push_back(log_[i % log_.size()]);
  return out;
}

SimTransport::SimTransport(const VirtualOmniParams& params, const ReportScaling& scaling,
                           SimFault fault)
    : device_(params, scaling, fault) {}

ReadResult SimTransport::read_latest() noexcept {
  if (device_.slow()) {
    timespec ts{0, 3'000'000};
    nanosleep(&ts, nullptr);
  }
  return drain_reports(
      [this](std::uint8_t* buf, std::size_t len) { return device_.read(buf, len); });
}

IoStatus SimTransport::write(const OutputReport& report) noexcept {
  std::uint8_t buf[kOutputReportSize];
  encode(report, buf);
  return device_.write(buf, sizeof buf) < 0 ? IoStatus::kDisconnected : IoStatus::kOk;
}

std::string SimTransport::describe() const {
  return "sim (virtual Omni, pose " + std::to_string(device_.plant().params().gamma1_deg) + "/" +
         std::to_string(device_.plant().params().gamma2_deg) + " deg)";
}

}  // namespace alphainv::device
