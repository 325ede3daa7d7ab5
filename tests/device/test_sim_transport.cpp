// The virtual device: one plant tick per output report, the reports it queues, and each injected
// fault's effect on the wire.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "alphainv/device/sim_transport.hpp"
#include "alphainv/error.hpp"

using namespace alphainv;
using namespace alphainv::device;

TEST(SimFault, Parses) {
  const SimFault f = parse_sim_fault("encoder-jump@1.5s");
  EXPECT_EQ(f.kind, SimFaultKind::kEncoderJump);
  EXPECT_DOUBLE_EQ(f.at_s, 1.5);
  EXPECT_EQ(parse_sim_fault("stall@0").kind, SimFaultKind::kStall);
  for (const char* bad : {"stall", "melt@1", "stall@", "stall@-1", "stall@x", "@1"}) {
    try {
      (void)parse_sim_fault(bad);
      FAIL() << bad;
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "--sim-fault");
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
    }
  }
}

TEST(SimTransport, StepsThePlantOncePerWriteAndReportsIt) {
  SimTransport t(VirtualOmniParams{}, ReportScaling{});
  VirtualOmni truth{VirtualOmniParams{}};
  OutputReport out;
  out.enable = true;
  for (int k = 0; k < 100; ++k) {
    const ReadResult in = t.read_latest();
    ASSERT_EQ(in.status, IoStatus::kOk);
    EXPECT_EQ(in.report.sequence, k);
    EXPECT_EQ(in.report.encoder_counts[0], ReportScaling{}.counts(0, truth.theta_measured()));
    out.sequence = static_cast<std::uint16_t>(k);
    out.dac_counts = static_cast<std::int16_t>(1000 * (k % 7) - 3000);
    ASSERT_EQ(t.write(out), IoStatus::kOk);
    truth.step(ReportScaling{}.command_v(out.dac_counts));
  }
  EXPECT_EQ(t.device().plant().theta(), truth.theta());
  // A disabled report applies 0 V whatever its DAC counts.
  out.enable = false;
  out.dac_counts = 30000;
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  truth.step(0.0);
  EXPECT_EQ(t.device().plant().theta(), truth.theta());
  const auto log = t.device().written();
  ASSERT_EQ(log.size(), 101u);
  EXPECT_FALSE(log.back().report.enable);
  EXPECT_EQ(log.back().device_tick, 100);
}

namespace {
/// Writes zero reports for `ticks` ticks and returns the last read.
ReadResult run_ticks(SimTransport& t, int ticks) {
  ReadResult last;
  for (int k = 0; k < ticks; ++k) {
    last = t.read_latest();
    (void)t.write(OutputReport{});
  }
  return last;
}
}  // namespace

TEST(SimTransport, InjectedFaultsOnTheWire) {
  {
    SimTransport t(VirtualOmniParams{}, ReportScaling{}, parse_sim_fault("stall@0.01"));
    EXPECT_EQ(run_ticks(t, 10).status, IoStatus::kOk);
    EXPECT_EQ(run_ticks(t, 1).status, IoStatus::kNoData);
    EXPECT_EQ(t.device().fault_tick(), 10);
  }
  {
    SimTransport t(VirtualOmniParams{}, ReportScaling{}, parse_sim_fault("sequence@0.01"));
    EXPECT_EQ(run_ticks(t, 10).report.sequence, 9);
    EXPECT_EQ(run_ticks(t, 1).report.sequence, 10 - 5);
  }
  {
    SimTransport t(VirtualOmniParams{}, ReportScaling{}, parse_sim_fault("encoder-jump@0.01"));
    const auto before = run_ticks(t, 10).report.encoder_counts[0];
    const auto after = run_ticks(t, 1).report.encoder_counts[0];
    EXPECT_NEAR((after - before) * 1.5e-4, 0.5, 2e-4);
  }
  {
    SimTransport t(VirtualOmniParams{}, ReportScaling{}, parse_sim_fault("corrupt@0.01"));
    EXPECT_EQ(run_ticks(t, 10).status, IoStatus::kOk);
    EXPECT_EQ(run_ticks(t, 1).decode, DecodeStatus::kBadChecksum);
  }
  {
    SimTransport t(VirtualOmniParams{}, ReportScaling{}, parse_sim_fault("disconnect@0.01"));
    EXPECT_EQ(run_ticks(t, 10).status, IoStatus::kOk);
    EXPECT_EQ(t.write(OutputReport{}), IoStatus::kDisconnected);
    EXPECT_EQ(t.read_latest().status, IoStatus::kDisconnected);
    EXPECT_FALSE(t.device().written().back().delivered);
  }
}

TEST(VirtualDevice, ItsWatchdogZeroesTheOutputWhenReportsStop) {
  // docs/hid-reports.md: no valid output report for longer than the watchdog period → 0 V and
  // status bit 2 (kStatusWatchdog). A wide period keeps a loaded machine from tripping it early.
  SimTransport t(VirtualOmniParams{}, ReportScaling{});
  VirtualDevice& dev = t.device();
  dev.set_watchdog_s(0.1);
  const ReportScaling scaling;
  OutputReport out;
  out.enable = true;
  out.dac_counts = scaling.dac(0.5);
  EXPECT_FALSE(dev.watchdog_tripped());  // never armed before the first report
  for (int k = 0; k < 20; ++k) {
    out.sequence = static_cast<std::uint16_t>(k);
    ASSERT_EQ(t.write(out), IoStatus::kOk);
  }
  EXPECT_DOUBLE_EQ(dev.applied_command_v(), scaling.command_v(out.dac_counts));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the host stops writing
  EXPECT_TRUE(dev.watchdog_tripped());
  EXPECT_EQ(dev.applied_command_v(), 0.0);  // the output stage holds 0 V on its own
  const ReadResult before = t.read_latest();
  ASSERT_EQ(before.status, IoStatus::kOk);
  EXPECT_EQ(before.report.status & kStatusWatchdog, 0);  // queued before the gap
  // A valid report re-arms it; the input report it produces says the watchdog had tripped.
  out.sequence = 20;
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  EXPECT_GE(dev.watchdog_trips(), 1);
  EXPECT_FALSE(dev.watchdog_tripped());
  const ReadResult after = t.read_latest();
  ASSERT_EQ(after.status, IoStatus::kOk);
  EXPECT_NE(after.report.status & kStatusWatchdog, 0);
  out.sequence = 21;
  ASSERT_EQ(t.write(out), IoStatus::kOk);
  EXPECT_EQ(t.read_latest().report.status & kStatusWatchdog, 0);  // reported once
  // An undecodable report does not feed the watchdog.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const std::uint8_t garbage[kOutputReportSize] = {0x02, 1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(dev.write(garbage, sizeof garbage), static_cast<int>(sizeof garbage));
  EXPECT_TRUE(dev.watchdog_tripped());
  EXPECT_EQ(dev.applied_command_v(), 0.0);
}
