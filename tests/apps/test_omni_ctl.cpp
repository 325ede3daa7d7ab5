// omni_ctl end to end, single-run mode: the real binary on the virtual device, and a build of it
// linked against the hidapi test double (tests/hid_double) so the HID path runs as on hardware.
// Each safety fault is injected into the device; the test checks the exit code and message, the
// reports that reached the device (zero and disabled within 2 ticks of detection), and that the
// recording up to the fault reads back with the dataset reader.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "alphainv/data/dataset.hpp"
#include "alphainv/data/model_file.hpp"
#include "hid_double/hid_double_state.hpp"
#include "support/subprocess.hpp"

using namespace alphainv;
using alphainv::test::ProcessResult;
using alphainv::test::run_process;
using alphainv::test::Subprocess;
namespace fs = std::filesystem;

namespace {

fs::path temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() /
                     ("alphainv_test_omni_ctl_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

/// One line of the hid double's log of output reports.
struct Written {
  long device_tick;
  int sequence, dac, enable, decoded, delivered, fault_active;
};

std::vector<Written> read_log(const fs::path& path) {
  std::vector<Written> out;
  std::ifstream f(path);
  std::string line;
  std::getline(f, line);  // header
  while (std::getline(f, line)) {
    Written w{};
    std::sscanf(line.c_str(), "%ld,%d,%d,%d,%d,%d,%d", &w.device_tick, &w.sequence, &w.dac,
                &w.enable, &w.decoded, &w.delivered, &w.fault_active);
    out.push_back(w);
  }
  return out;
}

// kLateWakeupsTolerated: a loaded test machine (ctest -j2, sanitizers) can wake the loop late
// ten times in a row, which is the deadline fault; tests of other behaviour raise the limit so
// that only the fault under test can stop the run. The deadline test keeps the default.
constexpr const char* kLateWakeupsTolerated = "100000";

std::vector<std::string> base_args(const char* bin, const fs::path& record,
                                   bool tolerate_late_wakeups = true) {
  std::vector<std::string> args = {bin,         "--joint",         "yaw", "--local",
                                   "--no-mlock", "--record", record.string()};
  if (tolerate_late_wakeups) {
    args.push_back("--max-missed");
    args.push_back(kLateWakeupsTolerated);
  }
  return args;
}

struct HidFaultCase {
  const char* name;
  const char* double_fault;  // ALPHAINV_HID_DOUBLE_FAULT, "" for none
  std::vector<std::string> extra_args;
  const char* message;          // expected in stderr
  const char* dataset_ended;    // expected in dataset.json
  int max_enabled_after_onset;  // enabled reports delivered after the device's fault onset
};

}  // namespace

TEST(OmniCtl, SimRunRecordsADatasetOmniFitReads) {
  const fs::path dir = temp_dir("sim");
  auto args = base_args(OMNI_CTL_BIN, dir / "rec");
  for (const char* a : {"--sine", "3Hz", "--duration", "1s", "--device", "sim"}) args.push_back(a);
  const ProcessResult r = run_process(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("wake-up latency"), std::string::npos) << r.err;
  const Dataset ds = read_dataset_index(dir / "rec");
  const RunData run = read_run(ds, 0);
  EXPECT_GE(run.size(), 950u);
  EXPECT_LE(run.size(), 1000u);
  EXPECT_EQ(ds.runs[0].kind, "sine");
  fs::remove_all(dir);
}

TEST(OmniCtl, HidRunThroughTheDoubleEndsDisabled) {
  const fs::path dir = temp_dir("hid_ok");
  auto args = base_args(OMNI_CTL_HID_DOUBLE_BIN, dir / "rec");
  for (const char* a : {"--square", "2Hz", "--duration", "0.6s", "--device", "hid:1209:0001"}) {
    args.push_back(a);
  }
  const ProcessResult r =
      run_process(args, {{"ALPHAINV_HID_DOUBLE_LOG", (dir / "log.csv").string()}});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto log = read_log(dir / "log.csv");
  ASSERT_GT(log.size(), 550u);
  long enabled = 0;
  for (const Written& w : log) enabled += w.enable;
  EXPECT_GT(enabled, 550);
  EXPECT_EQ(log.back().enable, 0);  // the exit report
  EXPECT_EQ(log.back().dac, 0);
  for (std::size_t i = 1; i < log.size(); ++i) {
    ASSERT_EQ(static_cast<std::uint16_t>(log[i].sequence - log[i - 1].sequence), 1) << i;
  }
  const RunData run = read_run(read_dataset_index(dir / "rec"), 0);
  EXPECT_GE(run.size(), 550u);
  fs::remove_all(dir);
}

TEST(OmniCtl, HidFaultsStopTheMotorAndKeepTheRecording) {
  const HidFaultCase cases[] = {
      {"disconnect",
       "disconnect@0.4",
       {},
       "FAULT: device disconnected",
       "fault: device disconnected",
       0},
      {"stall",
       "stall@0.4",
       {},
       "FAULT: input reports stalled",
       "fault: input reports stalled",
       20 + 2},
      {"corrupt",
       "corrupt@0.4",
       {},
       "FAULT: corrupt input report",
       "fault: corrupt input report",
       2},
      {"sequence",
       "sequence@0.4",
       {},
       "FAULT: input report out of sequence",
       "fault: input report out of sequence",
       2},
      {"encoder-jump", "encoder-jump@0.4", {}, "FAULT: encoder jump", "fault: encoder jump", 2},
      // 40 misses in a row, not the default 10: a loaded machine rarely wakes the loop late 40
      // times in a row, so the fault is the slow device's (every tick late after its onset).
      {"deadline",
       "slow@0.4",
       {"--max-missed", "40"},
       "FAULT: too many deadlines missed",
       "fault: too many deadlines",
       40 + 2},
      {"angle-limit",
       "",
       {"--theta-limit", "0.05"},
       "FAULT: angle limit exceeded",
       "fault: angle limit",
       0},
  };
  for (const HidFaultCase& fc : cases) {
    SCOPED_TRACE(fc.name);
    const fs::path dir = temp_dir(fc.name);
    const bool deadline_case = std::string(fc.name) == "deadline";
    auto args = base_args(OMNI_CTL_HID_DOUBLE_BIN, dir / "rec", !deadline_case);
    for (const char* a : {"--sine", "3Hz", "--duration", "2s", "--device", "hid"})
      args.push_back(a);
    for (const auto& a : fc.extra_args) args.push_back(a);
    const ProcessResult r =
        run_process(args, {{"ALPHAINV_HID_DOUBLE_FAULT", fc.double_fault},
                           {"ALPHAINV_HID_DOUBLE_LOG", (dir / "log.csv").string()}});
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_NE(r.err.find(fc.message), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("zeroed"), std::string::npos) << r.err;

    // On the wire: after the fault onset at most a few enabled reports, then only 0 / disabled.
    const auto log = read_log(dir / "log.csv");
    ASSERT_GT(log.size(), 50u);
    int enabled_after_onset = 0;
    std::size_t last_enabled = 0;
    for (std::size_t i = 0; i < log.size(); ++i) {
      if (log[i].fault_active && log[i].delivered && log[i].enable) ++enabled_after_onset;
      if (log[i].enable) last_enabled = i;
    }
    EXPECT_LE(enabled_after_onset, fc.max_enabled_after_onset);
    ASSERT_GE(log.size(), last_enabled + 2);  // the fault tick's report and the exit report
    for (std::size_t i = last_enabled + 1; i < log.size(); ++i) {
      EXPECT_EQ(log[i].enable, 0);
      EXPECT_EQ(log[i].dac, 0);
    }
    if (std::string(fc.name) == "angle-limit") {
      EXPECT_LT(log.size(), 1000u);  // stopped well before the 2 s
    }

    // The recording up to the fault.
    const Dataset ds = read_dataset_index(dir / "rec");
    const RunData run = read_run(ds, 0);
    EXPECT_GT(run.size(), 50u);
    EXPECT_EQ(run.column("torque_enable")->back(), 0.0);
    EXPECT_EQ(run.v.back(), 0.0);
    std::ifstream f(dir / "rec" / "dataset.json");
    std::stringstream json;
    json << f.rdbuf();
    EXPECT_NE(json.str().find(fc.dataset_ended), std::string::npos) << json.str().substr(0, 400);
    if (std::string(fc.double_fault).size() > 0) {
      // Device tick 400 carries the fault; the run began at loop tick 1 (stall: + 20 ticks to
      // detect, deadline: + 40 misses).
      EXPECT_GE(run.size(), 398u);
      EXPECT_LE(run.size(), deadline_case ? 445u : 425u);
    }
    fs::remove_all(dir);
  }
}

TEST(OmniCtl, SigtermZeroesAndFlushesTheRecording) {
  const fs::path dir = temp_dir("sigterm");
  auto args = base_args(OMNI_CTL_HID_DOUBLE_BIN, dir / "rec");
  for (const char* a : {"--sine", "2Hz", "--duration", "30s", "--device", "hid"}) args.push_back(a);
  Subprocess p(args, {{"ALPHAINV_HID_DOUBLE_LOG", (dir / "log.csv").string()}});
  std::this_thread::sleep_for(std::chrono::milliseconds(700));
  p.signal(SIGTERM);
  const ProcessResult r = p.wait(10.0);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("stopped by signal"), std::string::npos) << r.err;
  const RunData run = read_run(read_dataset_index(dir / "rec"), 0);
  EXPECT_GT(run.size(), 300u);
  EXPECT_LT(run.size(), 5000u);
  const auto log = read_log(dir / "log.csv");
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log.back().enable, 0);
  EXPECT_EQ(log.back().dac, 0);
  fs::remove_all(dir);
}

TEST(OmniCtl, BadInputIsRejectedWithTheFieldNamed) {
  const fs::path dir = temp_dir("bad");
  const std::string bin = OMNI_CTL_BIN;
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string message;
  };
  std::ofstream(dir / "broken.json") << "{\"schema\": \"alphainv-model/1\", ";
  const std::vector<Case> cases = {
      {{"--sine", "fastHz"}, 1, "--sine: expected a frequency like 3Hz"},
      {{"--square", "0Hz"}, 1, "--square: expected a frequency > 0 Hz"},
      {{"--sine", "3Hz", "--duration", "8min"}, 1, "--duration: expected a duration like 8s"},
      {{"--sine", "3Hz", "--kp", "50"}, 1, "--kp"},
      {{"--sine", "3Hz", "--square", "1Hz"}, 1, "excludes"},
      {{"--sine", "3Hz", "--duration", "-1s"}, 1, "--duration"},
      {{"--joint", "pitch", "--sine", "3Hz"}, 1, "--joint"},
      {{}, 1, "give a waveform"},
      {{"--sine", "3Hz", "--device", "usb"}, 2, "'--device'"},
      {{"--sine", "3Hz", "--device", "sim", "--sim-fault", "melt@1"}, 2, "'--sim-fault'"},
      {{"--sine", "3Hz", "--device", "sim", "--model", (dir / "missing.json").string()},
       2,
       "missing.json"},
      {{"--sine", "3Hz", "--device", "sim", "--model", (dir / "broken.json").string()},
       2,
       "broken.json"},
      {{"--hold", "--device", "sim", "--compensate", "all", "--compensate-damping", "0.5"},
       2,
       "'--compensate-damping': --compensate-damping needs --compensate effects"},
      {{"--hold", "--device", "sim", "--compensate", "effects", "--compensate-damping", "1"},
       1,
       "--compensate-damping"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {bin, "--local"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const ProcessResult r = run_process(args);
    EXPECT_EQ(r.exit_code, c.code) << c.message << ": " << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
  }
  // No device: exit 4, hidapi's reason in the message.
  const ProcessResult r =
      run_process({OMNI_CTL_HID_DOUBLE_BIN, "--local", "--sine", "3Hz", "--device", "hid"},
                  {{"ALPHAINV_HID_DOUBLE_ABSENT", "1"}});
  EXPECT_EQ(r.exit_code, 4) << r.err;
  EXPECT_NE(r.err.find("cannot open the HID device"), std::string::npos) << r.err;
  fs::remove_all(dir);
}

TEST(OmniCtl, WithoutRealtimePermissionItWarnsAndStillRuns) {
  if (getuid() != 0) GTEST_SKIP() << "needs root to drop to an unprivileged user";
  // As uid 65534 (nobody), with RLIMIT_RTPRIO inherited from this process.
  struct rlimit rt {};
  getrlimit(RLIMIT_RTPRIO, &rt);
  if (rt.rlim_cur >= 80) GTEST_SKIP() << "RLIMIT_RTPRIO allows SCHED_FIFO 80 to anyone here";
  // The clone may sit in a folder nobody else can enter (root's 0700 home, mktemp -d): give uid
  // 65534 its own copy of the binary in a folder it can reach (issue #13, finding 16).
  const fs::path reach = temp_dir("nobody");
  ASSERT_EQ(chmod(reach.c_str(), 0755), 0);
  for (fs::path p = reach.parent_path(); !p.empty() && p != p.root_path(); p = p.parent_path()) {
    struct stat st {};
    if (stat(p.c_str(), &st) == 0 && (st.st_mode & 0001) == 0) {
      GTEST_SKIP() << "uid 65534 cannot reach the temporary folder " << reach << " (" << p
                   << " is closed to others)";
    }
  }
  const fs::path bin = reach / "omni_ctl";
  fs::copy_file(OMNI_CTL_BIN, bin);
  ASSERT_EQ(chmod(bin.c_str(), 0755), 0);
  Subprocess probe({bin.string(), "--help"}, {}, 65534);
  const ProcessResult help = probe.wait(30.0);
  if (help.exit_code != 0) {
    fs::remove_all(reach);
    GTEST_SKIP() << "the copied binary does not start as uid 65534 (exit " << help.exit_code
                 << ": " << help.err.substr(0, 200) << "); a library it loads is out of reach";
  }
  Subprocess p({bin.string(), "--joint", "yaw", "--local", "--sine", "3Hz", "--duration", "0.3s",
                "--device", "sim", "--socket", "/nonexistent/omni_ctl.sock"},
               {}, 65534);
  const ProcessResult r = p.wait(30.0);
  fs::remove_all(reach);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warning: SCHED_FIFO priority 80 refused"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("normal scheduler"), std::string::npos) << r.err;
  const auto at = r.err.find("timing: ticks ");
  ASSERT_NE(at, std::string::npos) << r.err;
  EXPECT_GE(std::atol(r.err.c_str() + at + 14), 150) << r.err;  // the loop ran (~300 ticks)
}

TEST(OmniCtl, UsesTheModelFileForCAndBetaTilde) {
  const fs::path dir = temp_dir("model");
  ModelFile m;
  m.has_inertia_model = true;
  m.linear = paper_linear_model();
  m.linear.inertia.i_base *= 1.5;  // differs from the paper: the recording must follow the file
  m.has_alpha_model = true;
  m.alpha = paper_alpha_model();
  for (std::size_t n = 0; n < m.alpha.n_breakpoints; ++n) m.alpha.c_n1[n] *= 2.0;
  write_model_file(dir / "model.json", m);
  auto args = base_args(OMNI_CTL_BIN, dir / "rec");
  for (const char* a : {"--sine", "4Hz", "--duration", "0.5s", "--device", "sim"})
    args.push_back(a);
  args.push_back("--model");
  args.push_back((dir / "model.json").string());
  const ProcessResult r = run_process(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Dataset ds = read_dataset_index(dir / "rec");
  const RunData run = read_run(ds, 0);
  const auto& alpha = *run.column("alpha");
  const auto& c = *run.column("C");
  const auto& beta = *run.column("beta_tilde");
  const auto& g1 = *run.column("gamma1");
  const auto& g2 = *run.column("gamma2");
  double max_alpha = 0.0;
  for (std::size_t k = 0; k < run.size(); ++k) {
    const double inertia = m.linear.inertia.inertia(g1[k], g2[k]);
    ASSERT_NEAR(c[k], m.alpha.damping(alpha[k], inertia), 1e-9 * c[k]) << k;
    ASSERT_NEAR(beta[k], m.alpha.beta_tilde(alpha[k], inertia), 1e-9 * beta[k]) << k;
    max_alpha = std::max(max_alpha, alpha[k]);
  }
  EXPECT_GT(max_alpha, 2.2);  // α crossed a breakpoint: C really varied with α
  std::ifstream f(dir / "rec" / "dataset.json");
  std::stringstream json;
  json << f.rdbuf();
  EXPECT_NE(json.str().find("model.json"), std::string::npos);
  fs::remove_all(dir);
}

TEST(OmniCtl, ACrashZeroesTheMotorBeforeTheProcessEnds) {
  // std::terminate and each fatal signal, raised inside hid_read while the motor is driven (the
  // hid double's ALPHAINV_HID_DOUBLE_CRASH): the last report the device received is 0 and
  // disabled, and the process still dies of its signal. The double's state file is mapped
  // MAP_SHARED, so it outlives the crashed process.
  const fs::path dir = temp_dir("crash");
  const struct {
    const char* kind;
    int signal;
  } crashes[] = {{"terminate", SIGABRT}, {"segv", SIGSEGV}, {"abort", SIGABRT},
                 {"bus", SIGBUS},        {"fpe", SIGFPE},   {"ill", SIGILL}};
  for (const auto& c : crashes) {
    SCOPED_TRACE(c.kind);
    const fs::path state_file = dir / (std::string(c.kind) + ".state");
    const ProcessResult r = run_process(
        {OMNI_CTL_HID_DOUBLE_BIN, "--joint", "yaw", "--local", "--no-mlock", "--sine", "3Hz",
         "--duration", "2s", "--device", "hid", "--max-missed", kLateWakeupsTolerated},
        {{"ALPHAINV_HID_DOUBLE_CRASH", std::string(c.kind) + "@0.3"},
         {"ALPHAINV_HID_DOUBLE_STATE", state_file.string()}});
    EXPECT_EQ(r.exit_code, 128 + c.signal) << r.err;
    EXPECT_NE(r.err.find("a zero, disabled report was sent to the device"), std::string::npos)
        << r.err;
    test::HidDoubleState st;
    std::ifstream f(state_file, std::ios::binary);
    ASSERT_TRUE(f.read(reinterpret_cast<char*>(&st), sizeof st));
    ASSERT_EQ(st.magic, test::HidDoubleState::kMagic);
    EXPECT_GE(st.enabled_writes, 250u);  // the motor was driven for 0.3 s
    EXPECT_EQ(st.last_decoded, 1);
    EXPECT_EQ(st.last_enable, 0);
    EXPECT_EQ(st.last_dac, 0);
    // After the crash only the safe report (terminate: twice, then abort()'s SIGABRT handler).
    EXPECT_GE(st.writes, st.enabled_writes + 1);
    EXPECT_LE(st.writes, st.enabled_writes + 2);
  }
  // The daemon too: a crash on its loop thread, while it holds position between runs.
  const fs::path state_file = dir / "daemon.state";
  const ProcessResult r = run_process(
      {OMNI_CTL_HID_DOUBLE_BIN, "--daemon", "--no-mlock", "--device", "hid", "--max-missed",
       kLateWakeupsTolerated, "--socket", (dir / "run" / "omni_ctl.sock").string()},
      {{"ALPHAINV_HID_DOUBLE_CRASH", "segv@0.5"}, {"ALPHAINV_HID_DOUBLE_STATE", state_file.string()}},
      30.0);
  EXPECT_EQ(r.exit_code, 128 + SIGSEGV) << r.err;
  test::HidDoubleState st;
  std::ifstream f(state_file, std::ios::binary);
  ASSERT_TRUE(f.read(reinterpret_cast<char*>(&st), sizeof st));
  EXPECT_GE(st.enabled_writes, 400u);
  EXPECT_EQ(st.last_enable, 0);
  EXPECT_EQ(st.last_dac, 0);
  fs::remove_all(dir);
}
