#pragma once
/// \file device/sim_transport.hpp
/// The virtual Omni as a device: VirtualDevice speaks the HID reports of hid_report.hpp over
/// bytes (one plant tick per output report, one input report queued per tick) and injects
/// faults; SimTransport puts it behind the Transport interface in process. The hidapi test double
/// (tests/hid_double) wraps the same VirtualDevice behind the hid_* C API.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "alphainv/device/hid_report.hpp"
#include "alphainv/device/sim_push.hpp"
#include "alphainv/device/transport.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

namespace alphainv::device {

/// Faults the virtual device can inject.
enum class SimFaultKind {
  kNone,
  kDisconnect,     ///< reads and writes fail from then on (the cable is pulled)
  kStall,          ///< no more input reports; writes are accepted and ignored
  kCorrupt,        ///< input reports carry a wrong checksum
  kOutOfSequence,  ///< the input sequence number jumps back by 5
  kEncoderJump,    ///< the yaw encoder jumps by +0.5 rad and stays offset
  kSlow,           ///< each read takes 3 ms (the host misses its deadlines)
};

/// A fault and when it starts [s of device time: ticks stepped × T].
struct SimFault {
  SimFaultKind kind = SimFaultKind::kNone;
  double at_s = 0.0;
};

/// Parses "KIND@SECONDS" (KIND: disconnect, stall, corrupt, sequence, encoder-jump, slow; SECONDS
/// ≥ 0, an optional trailing "s"). Throws alphainv::Error naming `field` and the text.
SimFault parse_sim_fault(const std::string& text, const std::string& field = "--sim-fault");
/// Name of a fault kind as parse_sim_fault spells it.
const char* to_string(SimFaultKind kind) noexcept;

/// One output report as the device received it.
struct WrittenCommand {
  long device_tick = 0;       ///< plant ticks before this report (its index)
  OutputReport report;        ///< as decoded (dac 0, disabled when it did not decode)
  bool decoded = false;       ///< the report decoded
  bool delivered = false;     ///< the device was connected and accepted it
  bool fault_active = false;  ///< the injected fault was active when it arrived
};

/// The virtual Omni behind HID reports (see the file comment).
class VirtualDevice {
 public:
  /// Builds the plant (throws alphainv::Error naming a bad plant field) and queues the first input
  /// report. `log_capacity`: how many written commands are kept (the newest).
  VirtualDevice(const VirtualOmniParams& params, const ReportScaling& scaling, SimFault fault,
                std::size_t log_capacity = 8192);

  /// Takes one output report: steps the plant one tick with its command (0 V when disabled or
  /// undecodable) and queues the next input report. Returns `len`, or −1 when disconnected.
  /// Real-time safe.
  int write(const std::uint8_t* data, std::size_t len) noexcept;
  /// Pops the oldest queued input report into `buf`. Returns its length, 0 when none is queued,
  /// −1 when disconnected. Real-time safe.
  int read(std::uint8_t* buf, std::size_t len) noexcept;
  /// True when the injected fault is active now.
  bool fault_active() const noexcept;
  /// True when reads should take longer than a period (kSlow active).
  bool slow() const noexcept { return fault_active() && fault_.kind == SimFaultKind::kSlow; }

  const VirtualOmni& plant() const noexcept { return plant_; }
  const ReportScaling& scaling() const noexcept { return scaling_; }
  /// The newest written commands, oldest first (at most log_capacity). Not real-time.
  std::vector<WrittenCommand> written() const;
  /// Device tick at which the fault became active, or −1.
  long fault_tick() const noexcept { return fault_tick_; }
  /// The external torque applied from now on (sim_push.hpp; none by default). Real-time safe.
  void set_push(const SimPush& push) noexcept { push_ = push; }

  /// The device's own watchdog (docs/hid-reports.md): when no valid output report arrived for
  /// longer than watchdog_s of wall-clock time (CLOCK_MONOTONIC), the output stage applies 0 V
  /// whatever the last report said, and the next input report carries kStatusWatchdog. A valid
  /// report re-arms it. The plant's own time advances only with output reports, so the gap itself
  /// is not simulated: the watchdog models the output stage a dead host leaves behind.
  static constexpr double kDefaultWatchdogS = 0.010;
  void set_watchdog_s(double watchdog_s) noexcept { watchdog_s_ = watchdog_s; }
  /// True when the watchdog holds the output at 0 V now (no valid report for > watchdog_s).
  /// Real-time safe.
  bool watchdog_tripped() const noexcept;
  /// How many times the watchdog tripped (gaps longer than watchdog_s between valid reports).
  long watchdog_trips() const noexcept { return watchdog_trips_; }
  /// The voltage the output stage applies now [V]: the last valid report's command, 0 when it
  /// was disabled or the watchdog tripped. Real-time safe.
  double applied_command_v() const noexcept;

 private:
  void queue_report() noexcept;

  VirtualOmni plant_;
  ReportScaling scaling_;
  SimFault fault_;
  SimPush push_;
  long fault_tick_ = -1;
  std::uint16_t sequence_ = 0;
  static constexpr std::size_t kQueue = 256;
  std::array<std::array<std::uint8_t, kInputReportSize>, kQueue> queue_{};
  std::size_t queue_head_ = 0, queue_size_ = 0;
  std::vector<WrittenCommand> log_;  ///< ring of the newest commands, sized at construction
  std::size_t log_count_ = 0;
  double watchdog_s_ = kDefaultWatchdogS;
  long long last_valid_ns_ = -1;  ///< CLOCK_MONOTONIC of the last valid output report
  bool watchdog_report_ = false;  ///< the next input report carries kStatusWatchdog
  long watchdog_trips_ = 0;
  double last_v_ = 0.0;  ///< the last valid report's command (0 when disabled) [V]
};

/// VirtualDevice behind the Transport interface, in process.
class SimTransport final : public Transport {
 public:
  SimTransport(const VirtualOmniParams& params, const ReportScaling& scaling, SimFault fault = {});
  void open() override {}
  [[nodiscard]] ReadResult read_latest() noexcept override;
  [[nodiscard]] IoStatus write(const OutputReport& report) noexcept override;
  void close() noexcept override {}
  std::string describe() const override;
  VirtualDevice& device() noexcept { return device_; }

 private:
  VirtualDevice device_;
};

}  // namespace alphainv::device
