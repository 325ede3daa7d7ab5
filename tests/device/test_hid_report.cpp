// HID report codec: CRC check value, round trips, every corruption detected, scaling saturation.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "alphainv/device/hid_report.hpp"

using namespace alphainv::device;

TEST(Crc16, CcittFalseCheckValue) {
  const char* text = "123456789";
  EXPECT_EQ(crc16(reinterpret_cast<const std::uint8_t*>(text), 9), 0x29B1);
  EXPECT_EQ(crc16(nullptr, 0), 0xFFFF);
}

TEST(HidReport, InputRoundTripAndLayout) {
  InputReport in;
  in.sequence = 0xBEEF;
  in.encoder_counts = {-123456, 7000, 2147483647};
  in.status = kStatusMotorEnabled | kStatusWatchdog;
  std::uint8_t buf[kInputReportSize];
  encode(in, buf);
  EXPECT_EQ(buf[0], kInputReportId);
  EXPECT_EQ(buf[1], 0xEF);  // little-endian sequence
  EXPECT_EQ(buf[2], 0xBE);
  InputReport out;
  ASSERT_EQ(decode(buf, sizeof buf, out), DecodeStatus::kOk);
  EXPECT_EQ(out.sequence, in.sequence);
  EXPECT_EQ(out.encoder_counts, in.encoder_counts);
  EXPECT_EQ(out.status, in.status);
  // Longer buffers (a 64-byte read) decode too.
  std::uint8_t big[kMaxReportSize] = {};
  std::memcpy(big, buf, sizeof buf);
  EXPECT_EQ(decode(big, sizeof big, out), DecodeStatus::kOk);
}

TEST(HidReport, OutputRoundTripNegativeCommand) {
  OutputReport o;
  o.sequence = 65535;
  o.dac_counts = -32767;
  o.enable = true;
  std::uint8_t buf[kOutputReportSize];
  encode(o, buf);
  OutputReport back;
  ASSERT_EQ(decode(buf, sizeof buf, back), DecodeStatus::kOk);
  EXPECT_EQ(back.sequence, 65535);
  EXPECT_EQ(back.dac_counts, -32767);
  EXPECT_TRUE(back.enable);
}

TEST(HidReport, EverySingleBitFlipIsRejected) {
  InputReport in;
  in.sequence = 17;
  in.encoder_counts = {1, -2, 3};
  std::uint8_t buf[kInputReportSize];
  encode(in, buf);
  for (std::size_t byte = 1; byte < kInputReportSize; ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::uint8_t bad[kInputReportSize];
      std::memcpy(bad, buf, sizeof bad);
      bad[byte] ^= static_cast<std::uint8_t>(1u << bit);
      InputReport out;
      out.sequence = 999;
      EXPECT_EQ(decode(bad, sizeof bad, out), DecodeStatus::kBadChecksum) << byte << ":" << bit;
      EXPECT_EQ(out.sequence, 999);  // untouched
    }
  }
  InputReport out;
  EXPECT_EQ(decode(buf, kInputReportSize - 1, out), DecodeStatus::kWrongLength);
  buf[0] = kOutputReportId;
  EXPECT_EQ(decode(buf, sizeof buf, out), DecodeStatus::kWrongReportId);
  EXPECT_STREQ(to_string(DecodeStatus::kBadChecksum), "bad checksum");
}

TEST(ReportScaling, RoundsAndSaturates) {
  const ReportScaling s;
  EXPECT_EQ(s.dac(0.0), 0);
  EXPECT_EQ(s.dac(1.0), 6553);  // 32767/5 = 6553.4
  EXPECT_EQ(s.dac(-1.0), -6553);
  EXPECT_EQ(s.dac(100.0), 32767);
  EXPECT_EQ(s.dac(-100.0), -32767);
  EXPECT_EQ(s.dac(std::nan("")), 0);
  EXPECT_NEAR(s.command_v(6553), 6553.0 / 6553.4, 1e-15);
  EXPECT_EQ(s.counts(0, 1.5e-4 * 10), 10);
  EXPECT_EQ(s.counts(0, 1e9), 2147483647);
  EXPECT_EQ(s.counts(0, std::nan("")), -2147483647);
  EXPECT_NEAR(s.angle_rad(0, 6667), 6667 * 1.5e-4, 1e-12);
}

TEST(ReportScaling, DacRoundsAsStdRoundHalfAwayFromZero) {
  // dac() rounds without the library call: the same counts as std::round for every command,
  // ties included.
  const ReportScaling s;
  for (double counts : {0.5, -0.5, 1.5, -2.5, 0.49999999999999994, 6553.5, -32766.5, 32766.49}) {
    EXPECT_EQ(s.dac(counts / s.dac_counts_per_v),
              static_cast<std::int16_t>(std::round(counts / s.dac_counts_per_v * s.dac_counts_per_v)))
        << counts;
  }
  for (int k = -20000; k <= 20000; ++k) {
    const double v = k * 7.77e-5;
    ASSERT_EQ(s.dac(v), static_cast<std::int16_t>(std::round(v * s.dac_counts_per_v))) << v;
  }
}
