#pragma once
// Shared by the transports: drain input reports to the newest one. Not a public header.
#include <cstddef>
#include <cstdint>

#include "alphainv/device/hid_report.hpp"
#include "alphainv/device/transport.hpp"

namespace alphainv::device {

/// Calls `read(buf, len)` (returns bytes, 0 when none is pending, < 0 on failure) until nothing
/// is pending or Transport::kMaxDrain reports were read; keeps the newest report that decodes.
/// Real-time safe when `read` is.
template <class ReadFn>
ReadResult drain_reports(ReadFn&& read) noexcept {
  ReadResult result;
  std::uint8_t buf[kMaxReportSize];
  bool corrupt = false;
  for (int i = 0; i < Transport::kMaxDrain; ++i) {
    const int n = read(buf, sizeof buf);
    if (n < 0) {
      result.status = IoStatus::kDisconnected;
      return result;
    }
    if (n == 0) break;
    ++result.reports_read;
    InputReport report;
    const DecodeStatus d = decode(buf, static_cast<std::size_t>(n), report);
    if (d != DecodeStatus::kOk) {
      corrupt = true;
      result.decode = d;
      continue;
    }
    result.report = report;
    result.status = IoStatus::kOk;
  }
  if (corrupt) result.status = IoStatus::kCorrupt;
  return result;
}

}  // namespace alphainv::device
