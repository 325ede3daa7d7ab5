#include "alphainv/device/hid_report.hpp"

namespace alphainv::device {
namespace {

void put_u16(std::uint8_t* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v & 0xFFu);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
std::uint16_t get_u16(const std::uint8_t* p) noexcept {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
void put_i32(std::uint8_t* p, std::int32_t v) noexcept {
  const auto u = static_cast<std::uint32_t>(v);
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>((u >> (8 * i)) & 0xFFu);
}
std::int32_t get_i32(const std::uint8_t* p) noexcept {
  std::uint32_t u = 0;
  for (int i = 0; i < 4; ++i) u |= static_cast<std::uint32_t>(p[i]) << (8 * i);
  return static_cast<std::int32_t>(u);
}

}  // namespace

const char* to_string(DecodeStatus status) noexcept {
  switch (status) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kWrongLength:
      return "wrong length";
    case DecodeStatus::kWrongReportId:
      return "wrong report id";
    case DecodeStatus::kBadChecksum:
      return "bad checksum";
  }
  return "unknown";
}

std::uint16_t crc16(const std::uint8_t* data, std::size_t n) noexcept {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < n; ++i) {
    crc = static_cast<std::uint16_t>(crc ^ (static_cast<std::uint16_t>(data[i]) << 8));
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 0x8000u) ? static_cast<std::uint16_t>((crc << 1) ^ 0x1021u)
                            : static_cast<std::uint16_t>(crc << 1);
    }
  }
  return crc;
}

void encode(const InputReport& report, std::uint8_t* out) noexcept {
  out[0] = kInputReportId;
  put_u16(out + 1, report.sequence);
  for (std::size_t j = 0; j < 3; ++j) put_i32(out + 3 + 4 * j, report.encoder_counts[j]);
  put_u16(out + 15, report.status);
  put_u16(out + 17, crc16(out, 17));
}

void encode(const OutputReport& report, std::uint8_t* out) noexcept {
  out[0] = kOutputReportId;
  put_u16(out + 1, report.sequence);
  put_u16(out + 3, static_cast<std::uint16_t>(report.dac_counts));
  out[5] = report.enable ? 1 : 0;
  put_u16(out + 6, crc16(out, 6));
}

DecodeStatus decode(const std::uint8_t* data, std::size_t len, InputReport& out) noexcept {
  if (len < kInputReportSize) return DecodeStatus::kWrongLength;
  if (data[0] != kInputReportId) return DecodeStatus::kWrongReportId;
  if (crc16(data, 17) != get_u16(data + 17)) return DecodeStatus::kBadChecksum;
  out.sequence = get_u16(data + 1);
  for (std::size_t j = 0; j < 3; ++j) out.encoder_counts[j] = get_i32(data + 3 + 4 * j);
  out.status = get_u16(data + 15);
  return DecodeStatus::kOk;
}

DecodeStatus decode(const std::uint8_t* data, std::size_t len, OutputReport& out) noexcept {
  if (len < kOutputReportSize) return DecodeStatus::kWrongLength;
  if (data[0] != kOutputReportId) return DecodeStatus::kWrongReportId;
  if (crc16(data, 6) != get_u16(data + 6)) return DecodeStatus::kBadChecksum;
  out.sequence = get_u16(data + 1);
  out.dac_counts = static_cast<std::int16_t>(get_u16(data + 3));
  out.enable = (data[5] & 1u) != 0;
  return DecodeStatus::kOk;
}

}  // namespace alphainv::device
