#pragma once
/// \file device/hid_transport.hpp
/// The hidapi back end of Transport (Debian's libhidapi, hidraw backend): a USB HID joint
/// controller speaking the reports of docs/hid-reports.md. hid_enumerate/hid_open run only in
/// open(); the real-time calls are non-blocking hid_read_timeout(…, 0) and hid_write.

#include <cstdint>
#include <memory>
#include <string>

#include "alphainv/device/transport.hpp"

namespace alphainv::device {

/// Which device to open: a vendor/product id pair (first match) or a hidraw path.
struct HidDeviceSpec {
  std::uint16_t vendor_id = 0x1209;   ///< default: pid.codes test VID
  std::uint16_t product_id = 0x0001;  ///< default test PID
  std::string path;                   ///< when not empty, hid_open_path(path) instead of the ids

  /// Parses the text after "hid": "" (defaults), ":VID:PID" (hex) or ":PATH". Throws
  /// alphainv::Error naming `field`.
  static HidDeviceSpec parse(const std::string& text, const std::string& field = "--device");
};

/// Transport over hidapi (see the file comment).
class HidTransport final : public Transport {
 public:
  explicit HidTransport(HidDeviceSpec spec);
  ~HidTransport() override;
  HidTransport(const HidTransport&) = delete;
  HidTransport& operator=(const HidTransport&) = delete;

  /// hid_init, hid_open(_path), hid_set_nonblocking; throws alphainv::Error naming the device and
  /// hidapi's message.
  void open() override;
  [[nodiscard]] ReadResult read_latest() noexcept override;
  [[nodiscard]] IoStatus write(const OutputReport& report) noexcept override;
  void close() noexcept override;
  std::string describe() const override;
  std::string last_error() const override;

 private:
  HidDeviceSpec spec_;
  void* device_ = nullptr;  // hid_device*
};

}  // namespace alphainv::device
