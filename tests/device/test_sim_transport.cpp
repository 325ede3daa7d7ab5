// The virtual device: one plant tick per output report, the reports it queues, and each injected
// fault's effect on the wire.
#include <gtest/gtest.h>

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
