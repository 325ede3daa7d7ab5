#pragma once
/// \file device/transport.hpp
/// The abstract link to a joint controller: open, read the newest input report, write an output
/// report, close. Back ends: HidTransport (hidapi, hid_transport.hpp) and SimTransport (the virtual
/// Omni in process, sim_transport.hpp). The original Phantom Omni speaks IEEE 1394 (FireWire) and
/// the Touch a serial protocol over USB; a back end for either implements this interface and
/// converts to and from InputReport/OutputReport (docs/hid-reports.md).
///
/// Life cycle in the style of ros2_control: open() and close() are set-up calls (may allocate,
/// open() throws alphainv::Error naming the device); read_latest() and write() are the real-time
/// calls: noexcept, no allocation, no locks, and return a status.

#include <cstdint>
#include <string>

#include "alphainv/device/hid_report.hpp"

namespace alphainv::device {

/// Outcome of a real-time transport call.
enum class IoStatus {
  kOk,            ///< a report was read / written
  kNoData,        ///< no new input report since the last read
  kCorrupt,       ///< a report did not decode (length, id or checksum); see ReadResult::decode
  kDisconnected,  ///< the device is gone (read or write failed)
};

/// Name of an IoStatus ("ok", "no data", ...). Real-time safe.
const char* to_string(IoStatus status) noexcept;

/// Result of Transport::read_latest().
struct ReadResult {
  IoStatus status = IoStatus::kNoData;      ///< kOk: `report` is the newest input report
  InputReport report;                       ///< the newest report (valid when kOk)
  int reports_read = 0;                     ///< how many reports this call drained
  DecodeStatus decode = DecodeStatus::kOk;  ///< why a report was rejected (when kCorrupt)
};

/// A device link (see the file comment).
class Transport {
 public:
  virtual ~Transport() = default;
  /// Opens the device. Not real-time; throws alphainv::Error naming the device on failure.
  virtual void open() = 0;
  /// Drains every pending input report and returns the newest (never blocks; at most
  /// kMaxDrain reports per call). Any undecodable report makes the result kCorrupt.
  /// Real-time safe: no allocation, no locks, no I/O beyond the device read itself.
  [[nodiscard]] virtual ReadResult read_latest() noexcept = 0;
  /// Sends one output report. Real-time safe: no allocation, no locks, no I/O beyond the device
  /// write itself.
  [[nodiscard]] virtual IoStatus write(const OutputReport& report) noexcept = 0;
  /// Closes the device (idempotent). Not real-time.
  virtual void close() noexcept = 0;
  /// A one-line description ("hid 0x1234:0x5678 /dev/hidraw3", "sim"). Not real-time.
  virtual std::string describe() const = 0;
  /// The back end's own text for the last failure, or empty. Not real-time.
  virtual std::string last_error() const { return {}; }

  static constexpr int kMaxDrain = 64;  ///< most reports one read_latest() drains
};

}  // namespace alphainv::device
