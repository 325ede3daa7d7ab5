// HidTransport against the hidapi test double (tests/hid_double, linked in place of libhidapi):
// the real hid_* call sequence, report encoding on the wire, and the error paths.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <thread>

#include "alphainv/device/hid_transport.hpp"
#include "alphainv/error.hpp"
#include "alphainv/model/inertia_model.hpp"
#include "alphainv/simulate/virtual_omni.hpp"

using namespace alphainv;
using namespace alphainv::device;

namespace {

struct EnvGuard {
  explicit EnvGuard(const char* name, const char* value) : name_(name) { setenv(name, value, 1); }
  ~EnvGuard() { unsetenv(name_); }
  const char* name_;
};

}  // namespace

TEST(HidDeviceSpec, ParsesIdsPathsAndRejectsGarbage) {
  const HidDeviceSpec d = HidDeviceSpec::parse("");
  EXPECT_EQ(d.vendor_id, 0x1209);
  EXPECT_EQ(d.product_id, 0x0001);
  const HidDeviceSpec ids = HidDeviceSpec::parse(":046d:c52b");
  EXPECT_EQ(ids.vendor_id, 0x046d);
  EXPECT_EQ(ids.product_id, 0xc52b);
  EXPECT_EQ(HidDeviceSpec::parse(":/dev/hidraw3").path, "/dev/hidraw3");
  for (const char* bad : {":", ":zz:01", ":12345:1", ":0x12", "x"}) {
    try {
      (void)HidDeviceSpec::parse(bad);
      FAIL() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "--device") << bad;
    }
  }
}

TEST(HidTransport, ReadsTheVirtualOmniThroughTheHidApi) {
  HidTransport t(HidDeviceSpec::parse(""));
  t.open();
  const ReportScaling scaling;
  ReadResult in = t.read_latest();
  ASSERT_EQ(in.status, IoStatus::kOk);
  EXPECT_EQ(in.reports_read, 1);
  EXPECT_EQ(in.report.sequence, 0);
  EXPECT_EQ(in.report.encoder_counts[0], 0);
  const VirtualOmniParams p;
  EXPECT_NEAR(scaling.angle_rad(1, in.report.encoder_counts[1]), deg_to_rad(p.gamma1_deg), 1.5e-4);
  EXPECT_NEAR(scaling.angle_rad(2, in.report.encoder_counts[2]), deg_to_rad(p.gamma2_deg), 1.5e-4);
  EXPECT_EQ(t.read_latest().status, IoStatus::kNoData);  // nothing new until the device ticks

  // Drive +0.5 V for 50 ticks, reading nothing: the next read drains 50 reports to the newest.
  OutputReport out;
  out.enable = true;
  out.dac_counts = scaling.dac(0.5);
  for (int k = 0; k < 50; ++k) {
    out.sequence = static_cast<std::uint16_t>(k);
    ASSERT_EQ(t.write(out), IoStatus::kOk);
  }
  in = t.read_latest();
  ASSERT_EQ(in.status, IoStatus::kOk);
  EXPECT_EQ(in.reports_read, 50);
  EXPECT_EQ(in.report.sequence, 50);
  // Ground truth: the same plant stepped in process with the same DAC-rounded command.
  VirtualOmni truth(p);
  for (int k = 0; k < 50; ++k) truth.step(scaling.command_v(out.dac_counts));
  EXPECT_EQ(in.report.encoder_counts[0], scaling.counts(0, truth.theta_measured()));
  EXPECT_GT(truth.theta_measured(), 1e-3);
  t.close();
  t.close();  // idempotent
  EXPECT_EQ(t.read_latest().status, IoStatus::kDisconnected);
}

TEST(HidTransport, OpenFailuresNameTheDevice) {
  HidTransport wrong(HidDeviceSpec::parse(":dead:beef"));
  try {
    wrong.open();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.file(), "hid dead:beef");
    EXPECT_NE(std::string(e.what()).find("cannot open the HID device"), std::string::npos);
  }
  EnvGuard absent("ALPHAINV_HID_DOUBLE_ABSENT", "1");
  HidTransport t(HidDeviceSpec::parse(":/dev/hidraw-double"));
  EXPECT_THROW(t.open(), Error);
}

TEST(HidTransport, CorruptReportsAreRejected) {
  EnvGuard fault("ALPHAINV_HID_DOUBLE_FAULT", "corrupt@0.002");
  HidTransport t(HidDeviceSpec::parse(""));
  t.open();
  OutputReport out;
  EXPECT_EQ(t.read_latest().status, IoStatus::kOk);
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  EXPECT_EQ(t.read_latest().status, IoStatus::kOk);  // tick 1: before the fault
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  const ReadResult in = t.read_latest();
  EXPECT_EQ(in.status, IoStatus::kCorrupt);
  EXPECT_EQ(in.decode, DecodeStatus::kBadChecksum);
  EXPECT_EQ(in.reports_read, 2);
}

TEST(HidTransport, DisconnectFailsReadsAndWritesWithHidapisMessage) {
  EnvGuard fault("ALPHAINV_HID_DOUBLE_FAULT", "disconnect@0.001");
  HidTransport t(HidDeviceSpec::parse(""));
  t.open();
  OutputReport out;
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  EXPECT_EQ(t.write(out), IoStatus::kDisconnected);
  EXPECT_EQ(t.read_latest().status, IoStatus::kDisconnected);
  EXPECT_NE(t.last_error().find("disconnected"), std::string::npos) << t.last_error();
}

TEST(HidTransport, TheDevicesWatchdogReportsAHostThatStoppedWriting) {
  // docs/hid-reports.md: with no output report for more than the device's watchdog period (10 ms
  // in the double) the device zeroes the motor by itself and sets status bit 2; a dead or hung
  // host (SIGKILL, a stalled loop) leaves exactly that behind.
  HidTransport t(HidDeviceSpec::parse(""));
  t.open();
  OutputReport out;
  out.enable = true;
  out.dac_counts = ReportScaling{}.dac(0.3);
  ASSERT_EQ(t.read_latest().status, IoStatus::kOk);
  for (int k = 0; k < 5; ++k) {
    out.sequence = static_cast<std::uint16_t>(k);
    ASSERT_EQ(t.write(out), IoStatus::kOk);
  }
  (void)t.read_latest();
  std::this_thread::sleep_for(std::chrono::milliseconds(60));  // the host stops for 60 ms
  out.sequence = 5;
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  const ReadResult in = t.read_latest();
  ASSERT_EQ(in.status, IoStatus::kOk);
  EXPECT_NE(in.report.status & kStatusWatchdog, 0) << in.report.status;
  t.close();
}
