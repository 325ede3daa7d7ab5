#pragma once
/// \file device/hid_report.hpp
/// The HID reports between omni_ctl and a USB joint controller (docs/hid-reports.md): encoding,
/// decoding, the CRC-16 checksum, and the scaling of encoder counts and DAC counts.
///
/// Input report (device → host, report id 0x01, 19 bytes with the id), little-endian:
///   [0] id 0x01 | [1..2] sequence u16 | [3..6] [7..10] [11..14] encoder counts i32 of the yaw
///   joint, γ1 and γ2 | [15..16] status flags u16 | [17..18] CRC-16/CCITT-FALSE of bytes 0..16.
/// Output report (host → device, report id 0x02, 8 bytes with the id):
///   [0] id 0x02 | [1..2] sequence u16 | [3..4] motor command i16 DAC counts | [5] flags (bit 0:
///   enable) | [6..7] CRC-16/CCITT-FALSE of bytes 0..5.
///
/// Everything here is real-time safe: no allocation, no locks, no I/O.

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>

namespace alphainv::device {

inline constexpr std::uint8_t kInputReportId = 0x01;   ///< input report id
inline constexpr std::uint8_t kOutputReportId = 0x02;  ///< output report id
inline constexpr std::size_t kInputReportSize = 19;    ///< input report bytes, with the id
inline constexpr std::size_t kOutputReportSize = 8;    ///< output report bytes, with the id
inline constexpr std::size_t kMaxReportSize = 64;      ///< largest report a transport reads

/// Input status flags (bits of InputReport::status).
enum InputStatusFlag : std::uint16_t {
  kStatusMotorEnabled = 1u << 0,    ///< the amplifier is enabled
  kStatusAmplifierFault = 1u << 1,  ///< the amplifier reports a fault (over-current, thermal)
  kStatusWatchdog = 1u << 2,  ///< the device's own watchdog zeroed the motor (no output reports)
};

/// One input report: the device's state at one sample.
struct InputReport {
  std::uint16_t sequence = 0;                    ///< increments by one per report, wraps
  std::array<std::int32_t, 3> encoder_counts{};  ///< yaw θ, γ1, γ2 [counts]
  std::uint16_t status = 0;                      ///< InputStatusFlag bits
};

/// One output report: the motor command.
struct OutputReport {
  std::uint16_t sequence = 0;   ///< increments by one per report, wraps
  std::int16_t dac_counts = 0;  ///< motor command [DAC counts]
  bool enable = false;          ///< amplifier enable
};

/// Why a report did not decode.
enum class DecodeStatus {
  kOk,
  kWrongLength,    ///< fewer bytes than the report
  kWrongReportId,  ///< first byte is not the expected id
  kBadChecksum,    ///< CRC mismatch
};

/// Name of a DecodeStatus ("ok", "wrong length", ...). Real-time safe.
const char* to_string(DecodeStatus status) noexcept;

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection) of `n` bytes. Check value:
/// crc16("123456789") = 0x29B1. Real-time safe: no allocation, no locks, no I/O.
std::uint16_t crc16(const std::uint8_t* data, std::size_t n) noexcept;

/// Writes `report` into `out` (kInputReportSize bytes). Real-time safe.
void encode(const InputReport& report, std::uint8_t* out) noexcept;
/// Writes `report` into `out` (kOutputReportSize bytes). Real-time safe.
void encode(const OutputReport& report, std::uint8_t* out) noexcept;
/// Decodes `len` bytes into `out` (untouched unless kOk). Real-time safe.
[[nodiscard]] DecodeStatus decode(const std::uint8_t* data, std::size_t len,
                                  InputReport& out) noexcept;
/// Decodes `len` bytes into `out` (untouched unless kOk). Real-time safe.
[[nodiscard]] DecodeStatus decode(const std::uint8_t* data, std::size_t len,
                                  OutputReport& out) noexcept;

/// Conversion between physical units and report counts.
struct ReportScaling {
  /// Encoder counts per radian of θ, γ1, γ2 (default: 1.5e-4 rad per count, the Omni's step).
  std::array<double, 3> counts_per_rad{{1.0 / 1.5e-4, 1.0 / 1.5e-4, 1.0 / 1.5e-4}};
  double dac_counts_per_v = 32767.0 / 5.0;  ///< DAC counts per volt (±5 V full scale)

  /// Angle of joint j [rad] from its counts. Real-time safe.
  double angle_rad(std::size_t j, std::int32_t counts) const noexcept {
    return static_cast<double>(counts) / counts_per_rad[j];
  }
  /// Nearest counts of an angle [rad] of joint j, saturated to int32. Real-time safe.
  std::int32_t counts(std::size_t j, double angle_rad) const noexcept {
    const double c = std::round(angle_rad * counts_per_rad[j]);
    if (!(c > -2147483647.0)) return -2147483647;  // also NaN
    if (c > 2147483647.0) return 2147483647;
    return static_cast<std::int32_t>(c);
  }
  /// Nearest DAC counts of a command [V], saturated to ±32767 (NaN → 0). Real-time safe.
  std::int16_t dac(double command_v) const noexcept {
    const double x = command_v * dac_counts_per_v;
    if (std::isnan(x)) return 0;
    if (x >= 32767.0) return 32767;
    if (x <= -32767.0) return -32767;
    // std::round (half away from zero) without the library call: t = trunc(x) and x − t are
    // exact for |x| < 2^52.
    const auto t = static_cast<std::int32_t>(x);
    const double frac = x - static_cast<double>(t);
    // (The comparisons as integers, not a branch: frac is noise and a branch on it mispredicted
    // on half the ticks, callgrind --branch-sim.)
    return static_cast<std::int16_t>(t + static_cast<std::int32_t>(frac >= 0.5) -
                                     static_cast<std::int32_t>(frac <= -0.5));
  }
  /// Command [V] of DAC counts. Real-time safe.
  double command_v(std::int16_t dac_counts) const noexcept {
    return static_cast<double>(dac_counts) / dac_counts_per_v;
  }
};

}  // namespace alphainv::device
