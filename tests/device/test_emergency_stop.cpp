// The crash path (device/emergency_stop.hpp): while armed, std::terminate and the fatal signals
// write a zero, disabled output report through the transport before the process ends; unarmed,
// nothing is written. The death tests run the crash in a child and read what it wrote through a
// pipe, as the device would have received it.
#include "alphainv/device/emergency_stop.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <exception>

#include "alphainv/device/loop_runner.hpp"
#include "alphainv/device/sim_transport.hpp"

using namespace alphainv;
using namespace alphainv::device;

namespace {

/// A transport whose write() sends the encoded report down a pipe (one write(2): what a hidraw
/// device's write is), so a parent process sees what a crashed child sent last.
class PipeTransport final : public Transport {
 public:
  explicit PipeTransport(int fd) : fd_(fd) {}
  void open() override {}
  ReadResult read_latest() noexcept override { return {}; }
  IoStatus write(const OutputReport& report) noexcept override {
    std::uint8_t buf[kOutputReportSize];
    encode(report, buf);
    return ::write(fd_, buf, sizeof buf) == static_cast<ssize_t>(sizeof buf) ? IoStatus::kOk
                                                                             : IoStatus::kDisconnected;
  }
  void close() noexcept override {}
  std::string describe() const override { return "pipe"; }

 private:
  int fd_;
};

/// Everything the child wrote, as output reports.
std::vector<OutputReport> read_reports(int fd) {
  std::vector<OutputReport> out;
  std::uint8_t buf[kOutputReportSize];
  while (::read(fd, buf, sizeof buf) == static_cast<ssize_t>(sizeof buf)) {
    OutputReport r;
    if (decode(buf, sizeof buf, r) == DecodeStatus::kOk) out.push_back(r);
  }
  return out;
}

/// Runs `crash` in a death-test child with a PipeTransport armed after an enabled report with
/// sequence 41; returns what reached the pipe.
template <typename Crash>
std::vector<OutputReport> reports_of_a_crash(Crash crash, int expected_signal) {
  int fds[2];
  EXPECT_EQ(pipe(fds), 0);
  EXPECT_EXIT(
      {
        close(fds[0]);
        install_crash_handlers();
        PipeTransport t(fds[1]);
        OutputReport driving;
        driving.sequence = 41;
        driving.dac_counts = 12000;
        driving.enable = true;
        (void)t.write(driving);
        arm_emergency_stop(t);
        note_sequence(41);
        crash();
      },
      ::testing::KilledBySignal(expected_signal), "zero, disabled report was sent");
  close(fds[1]);
  std::vector<OutputReport> out = read_reports(fds[0]);
  close(fds[0]);
  return out;
}

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpragmas"
#pragma GCC diagnostic ignored "-Winfinite-recursion"
/// Overflows the stack (4 KiB a frame) until the guard page: SIGSEGV.
int recurse_forever(int depth) {
  volatile char pad[4096];
  pad[depth % 4096] = 1;
  return recurse_forever(depth + 1) + pad[0];
}
#pragma GCC diagnostic pop

}  // namespace

TEST(EmergencyStop, WritesNothingUnlessArmed) {
  SimTransport t(VirtualOmniParams{}, ReportScaling{});
  disarm_emergency_stop();
  EXPECT_FALSE(emergency_stop());
  EXPECT_TRUE(t.device().written().empty());
  OutputReport driving;
  driving.sequence = 7;
  driving.enable = true;
  driving.dac_counts = 3000;
  ASSERT_EQ(t.write(driving), IoStatus::kOk);
  arm_emergency_stop(t);
  note_sequence(7);
  EXPECT_TRUE(emergency_stop());
  const WrittenCommand last = t.device().written().back();
  EXPECT_TRUE(last.decoded);
  EXPECT_FALSE(last.report.enable);
  EXPECT_EQ(last.report.dac_counts, 0);
  EXPECT_EQ(last.report.sequence, 8);  // continues the loop's sequence
  EXPECT_TRUE(emergency_stop());
  EXPECT_EQ(t.device().written().back().report.sequence, 9);
  disarm_emergency_stop();
  EXPECT_FALSE(emergency_stop());
  EXPECT_EQ(t.device().written().size(), 3u);
}

TEST(EmergencyStop, TheLoopRunnerArmsItOnlyWhileItRuns) {
  SimTransport t(VirtualOmniParams{}, ReportScaling{});
  LoopRunnerOptions o;
  o.exit_when_idle = true;
  LoopRunner runner(t, rt::ControlLoopConfig{}, o);
  LoopCommand c;
  c.kind = LoopCommand::Kind::kRun;
  c.wave = rt::Waveform{rt::WaveKind::kSine, 0.05, 3.0, 0.0};
  c.duration_s = 0.05;
  c.run_id = 1;
  ASSERT_TRUE(runner.post(c));
  std::atomic<bool> stop{false};
  EXPECT_FALSE(emergency_stop());
  (void)runner.run(stop);
  EXPECT_FALSE(emergency_stop());  // disarmed after the loop's own last (safe) report
  EXPECT_FALSE(t.device().written().back().report.enable);
}

TEST(EmergencyStopDeathTest, FatalSignalsSendTheSafeReportFirst) {
  for (int sig : {SIGSEGV, SIGABRT, SIGBUS, SIGFPE, SIGILL}) {
    SCOPED_TRACE(strsignal(sig));
    const auto reports = reports_of_a_crash([sig] { raise(sig); }, sig);
    ASSERT_EQ(reports.size(), 2u);  // the driving report, then the emergency one
    EXPECT_TRUE(reports[0].enable);
    EXPECT_FALSE(reports[1].enable);
    EXPECT_EQ(reports[1].dac_counts, 0);
    EXPECT_EQ(reports[1].sequence, 42);
  }
}

TEST(EmergencyStopDeathTest, StdTerminateSendsTheSafeReportFirst) {
  const auto reports = reports_of_a_crash([] { std::terminate(); }, SIGABRT);
  // std::terminate writes it, then abort()'s SIGABRT handler once more: both zero and disabled.
  ASSERT_GE(reports.size(), 2u);
  EXPECT_TRUE(reports[0].enable);
  for (std::size_t i = 1; i < reports.size(); ++i) {
    EXPECT_FALSE(reports[i].enable);
    EXPECT_EQ(reports[i].dac_counts, 0);
  }
}

TEST(EmergencyStopDeathTest, AStackOverflowStillReachesTheHandler) {
  const auto reports = reports_of_a_crash(
      [] { (void)recurse_forever(0); },
      SIGSEGV);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_FALSE(reports[1].enable);
  EXPECT_EQ(reports[1].dac_counts, 0);
}
