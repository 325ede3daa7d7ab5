#include "alphainv/device/hid_transport.hpp"

#include <hidapi/hidapi.h>

#include <cstdio>
#include <cstdlib>
#include <cwchar>

#include "alphainv/error.hpp"
#include "drain.hpp"

namespace alphainv::device {
namespace {

hid_device* dev(void* p) { return static_cast<hid_device*>(p); }

std::string narrow(const wchar_t* w) {
  if (w == nullptr) return {};
  std::string out;
  for (; *w != 0; ++w) out += (*w < 128) ? static_cast<char>(*w) : '?';
  return out;
}

bool parse_hex16(const std::string& s, std::uint16_t& out) {
  if (s.empty() || s.size() > 6) return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(s.c_str(), &end, 16);
  if (end != s.c_str() + s.size() || v > 0xFFFF) return false;
  out = static_cast<std::uint16_t>(v);
  return true;
}

}  // namespace

HidDeviceSpec HidDeviceSpec::parse(const std::string& text, const std::string& field) {
  HidDeviceSpec spec;
  if (text.empty()) return spec;
  const std::string expected = "expected hid, hid:VID:PID (hex) or hid:PATH, got 'hid" + text + "'";
  if (text[0] != ':' || text.size() == 1) throw Error(expected, {}, 0, field);
  const std::string rest = text.substr(1);
  if (rest[0] == '/') {
    spec.path = rest;
    return spec;
  }
  const auto colon = rest.find(':');
  if (colon == std::string::npos || !parse_hex16(rest.substr(0, colon), spec.vendor_id) ||
      !parse_hex16(rest.substr(colon + 1), spec.product_id)) {
    throw Error(expected, {}, 0, field);
  }
  return spec;
}

HidTransport::HidTransport(HidDeviceSpec spec) : spec_(std::move(spec)) {}
HidTransport::~HidTransport() { close(); }

void HidTransport::open() {
  if (device_ != nullptr) return;
  if (hid_init() != 0) throw Error("hid_init failed: " + narrow(hid_error(nullptr)), describe());
  device_ = spec_.path.empty() ? hid_open(spec_.vendor_id, spec_.product_id, nullptr)
                               : hid_open_path(spec_.path.c_str());
  if (device_ == nullptr) {
    throw Error("cannot open the HID device: " + narrow(hid_error(nullptr)) +
                    " (is it plugged in, and may this user read /dev/hidraw*?)",
                describe());
  }
  if (hid_set_nonblocking(dev(device_), 1) != 0) {
    const std::string why = narrow(hid_error(dev(device_)));
    close();
    throw Error("hid_set_nonblocking failed: " + why, describe());
  }
}

ReadResult HidTransport::read_latest() noexcept {
  if (device_ == nullptr) {
    ReadResult r;
    r.status = IoStatus::kDisconnected;
    return r;
  }
  return drain_reports([this](std::uint8_t* buf, std::size_t len) {
    return hid_read_timeout(dev(device_), buf, len, 0);
  });
}

IoStatus HidTransport::write(const OutputReport& report) noexcept {
  if (device_ == nullptr) return IoStatus::kDisconnected;
  std::uint8_t buf[kOutputReportSize];
  encode(report, buf);
  return hid_write(dev(device_), buf, sizeof buf) < 0 ? IoStatus::kDisconnected : IoStatus::kOk;
}

void HidTransport::close() noexcept {
  if (device_ != nullptr) {
    hid_close(dev(device_));
    device_ = nullptr;
    hid_exit();
  }
}

std::string HidTransport::describe() const {
  if (!spec_.path.empty()) return "hid " + spec_.path;
  char ids[32];
  std::snprintf(ids, sizeof ids, "hid %04x:%04x", spec_.vendor_id, spec_.product_id);
  return ids;
}

std::string HidTransport::last_error() const {
  return narrow(hid_error(device_ == nullptr ? nullptr : dev(device_)));
}

}  // namespace alphainv::device
