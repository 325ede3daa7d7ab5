// omni_ctl: the 1 kHz real-time controller of the Omni's yaw joint (docs/omni_ctl.md).
//   omni_ctl --joint yaw (--sine 3Hz | --square 0.25Hz | --step | --hold) [--amplitude 0.07]
//            [--kp 2] [--duration 10s] [--record DIR] [--model model.json]
//            [--device hid[:VID:PID|:PATH] | sim] [--max-command 1.0] [--sim-fault KIND@S]
//   omni_ctl --daemon [--device ...]   the foreground service on a Unix socket
// With a waveform it talks to a running daemon when there is one, else runs the loop itself.
#include <signal.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "alphainv/device/loop_runner.hpp"
#include "alphainv/error.hpp"
#include "options.hpp"

/// Set by SIGINT/SIGTERM (and by the daemon when it ends); the loop and the server watch it.
std::atomic<bool> g_omni_ctl_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

namespace {

using namespace alphainv;
using namespace omni_ctl;

std::atomic<bool>& g_stop = g_omni_ctl_stop;

extern "C" void on_signal(int) { g_omni_ctl_stop.store(true); }

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

int fail(int code, const std::string& message) {
  std::fprintf(stderr, "omni_ctl: %s\n", message.c_str());
  return code;
}

/// "3Hz", "0.25 Hz", "3" → Hz; "10s", "500ms", "10" → s. Throws CLI::ValidationError.
double parse_with_unit(const std::string& option, const std::string& text, const std::string& unit,
                       double scale_small, const std::string& small_unit) {
  std::string s = text;
  while (!s.empty() && s.back() == ' ') s.pop_back();
  double factor = 1.0;
  auto ends_with = [&](const std::string& u) {
    return s.size() >= u.size() && s.compare(s.size() - u.size(), u.size(), u) == 0;
  };
  if (!small_unit.empty() && ends_with(small_unit)) {
    s.resize(s.size() - small_unit.size());
    factor = scale_small;
  } else if (ends_with(unit)) {
    s.resize(s.size() - unit.size());
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(x) || !(x > 0.0)) {
    throw CLI::ValidationError(option + ": expected a positive number with an optional unit " +
                               unit + ", got '" + text + "'");
  }
  return x * factor;
}

std::string command_line(int argc, char** argv) {
  std::string out = "omni_ctl";
  for (int i = 1; i < argc; ++i) out += std::string(" ") + argv[i];
  return out;
}

int run_local(const Options& opt) {
  std::string model_source, model_note;
  rt::ControlLoopConfig cfg;
  std::unique_ptr<device::Transport> transport;
  try {
    cfg = make_loop_config(opt, model_source, model_note);
    transport = make_transport(opt);
  } catch (const Error& e) {
    return fail(kExitBadInput, e.what());
  }
  if (!model_note.empty()) std::fprintf(stderr, "omni_ctl: note: %s\n", model_note.c_str());
  try {
    transport->open();
  } catch (const Error& e) {
    return fail(kExitDevice, e.what());
  }

  device::LoopRunnerOptions ro;
  ro.exit_when_idle = true;
  std::unique_ptr<device::LoopRunner> runner;
  try {
    runner = std::make_unique<device::LoopRunner>(*transport, cfg, ro);
  } catch (const Error& e) {
    transport->close();
    return fail(kExitBadInput, e.what());
  }
  const device::LoopCommand run = make_run_command(opt, 1);
  if (!opt.record_dir.empty()) {
    device::RunRecording rec;
    rec.dir = opt.record_dir;
    rec.wave = run.wave;
    rec.command_line = opt.command_line;
    rec.device = transport->describe();
    rec.model_source = model_source;
    runner->add_recording(1, rec);
  }
  (void)runner->post(run);

  const device::RealtimeSetup rt_setup = device::request_realtime(opt.rt_priority, !opt.no_mlock);
  for (const auto& w : rt_setup.warnings)
    std::fprintf(stderr, "omni_ctl: warning: %s\n", w.c_str());
  std::fprintf(stderr, "omni_ctl: %s on %s, kp %g, %s%s%s\n", opt.wave_kind.c_str(),
               transport->describe().c_str(), opt.kp,
               rt_setup.fifo ? "SCHED_FIFO" : "normal scheduler",
               rt_setup.locked ? ", memory locked" : "",
               rt_setup.cpu_dma_latency_zero ? ", cpu_dma_latency 0" : "");

  const device::LoopOutcome outcome = runner->run(g_stop);
  device::RunResult result;
  const bool have_result = runner->wait_run(1, 30.0, result);
  transport->close();

  std::fprintf(stderr, "omni_ctl: %s", outcome.full_report().c_str());
  if (!opt.record_dir.empty()) {
    std::fprintf(stderr, "omni_ctl: %s\n",
                 have_result ? result.brief_report().c_str()
                             : ("the recording did not finish in time: " + opt.record_dir).c_str());
  }
  int code = kExitOk;
  if (!outcome.usable()) {
    code = kExitFault;
  } else if (!opt.record_dir.empty() && (!have_result || !result.usable())) {
    code = kExitRecording;
  }
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"omni_ctl: the 1 kHz real-time controller of the Phantom Omni yaw joint"};
  Options opt;
  opt.command_line = command_line(argc, argv);
  std::string sine, square;
  bool step = false, hold = false;
  std::string duration;
  app.add_option("--joint", opt.joint, "the joint to drive (only 'yaw')")->capture_default_str();
  auto* o_sine = app.add_option("--sine", sine, "sine reference at this frequency, e.g. 3Hz");
  auto* o_square = app.add_option("--square", square, "square reference, e.g. 0.25Hz");
  auto* o_step = app.add_flag("--step", step, "a step of --amplitude");
  auto* o_hold = app.add_flag("--hold", hold, "hold the current position");
  app.add_option("--amplitude", opt.amplitude_rad, "reference amplitude [rad]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--kp", opt.kp, "P gain [V/rad]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  app.add_option("--duration", duration, "run length, e.g. 10s or 500ms (default 10s)");
  app.add_option("--record", opt.record_dir, "write the run as a dataset (alphainv-dataset/1)");
  app.add_option("--model", opt.model_path, "model.json (omni_fit); default: the paper's model");
  app.add_option("--device", opt.device, "hid, hid:VID:PID (hex), hid:PATH or sim")
      ->capture_default_str();
  app.add_option("--max-command", opt.safety.max_command_v, "command clamp [V]")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 5.0));
  app.add_option("--max-slew", opt.safety.max_slew_v_per_s, "command slew limit [V/s]")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 1e6));
  app.add_option("--theta-limit", opt.safety.theta_limit_rad, "angle limit |theta| [rad]")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 10.0));
  app.add_option("--stall-periods", opt.safety.stall_periods,
                 "periods without an input report before a stall fault")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-missed", opt.safety.max_missed_deadlines,
                 "deadline misses in a row before a fault")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--sim-fault", opt.sim_fault,
                 "inject a fault into --device sim: KIND@SECONDS, KIND = disconnect, stall, "
                 "corrupt, sequence, encoder-jump, slow");
  app.add_option("--rt-priority", opt.rt_priority, "SCHED_FIFO priority, 0 = normal scheduler")
      ->capture_default_str()
      ->check(CLI::Range(0, 99));
  app.add_flag("--no-mlock", opt.no_mlock, "do not mlockall");
  app.add_flag("--daemon", opt.daemon, "run as the foreground service on a Unix socket");
  app.add_flag("--local", opt.local, "run the loop here even when a daemon is running");
  app.add_option("--socket", opt.socket_path,
                 "daemon socket (default: " + default_socket_path() + ")");
  app.add_option("--stream", opt.stream_hz, "with a daemon: print the state at this rate [Hz]")
      ->check(CLI::Range(0.0, 1000.0));
  o_sine->excludes(o_square)->excludes(o_step)->excludes(o_hold);
  o_square->excludes(o_step)->excludes(o_hold);
  o_step->excludes(o_hold);
  app.footer(
      "Exit codes: 0 ok (also after SIGINT/SIGTERM), 1 usage, 2 bad input, 3 safety fault, 4 "
      "device or daemon unavailable, 5 recording failed.\n"
      "Example:\n  omni_ctl --joint yaw --sine 3Hz --duration 5s --device sim --record /tmp/run");
  try {
    app.parse(argc, argv);
    if (!sine.empty()) {
      opt.wave_kind = "sine";
      opt.freq_hz = parse_with_unit("--sine", sine, "Hz", 0.0, "");
    } else if (!square.empty()) {
      opt.wave_kind = "square";
      opt.freq_hz = parse_with_unit("--square", square, "Hz", 0.0, "");
    } else if (step) {
      opt.wave_kind = "step";
    } else if (hold) {
      opt.wave_kind = "hold";
    }
    if (!duration.empty())
      opt.duration_s = parse_with_unit("--duration", duration, "s", 1e-3, "ms");
    if (opt.freq_hz > 100.0)
      throw CLI::ValidationError("--sine/--square: expected a frequency up to 100 Hz");
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "omni_ctl: %s\nRun 'omni_ctl --help' for usage.\n", e.what());
    return kExitUsage;
  }
  if (opt.joint != "yaw")
    return fail(kExitUsage, "--joint: only 'yaw' is supported, got '" + opt.joint + "'");
  if (opt.socket_path.empty()) opt.socket_path = default_socket_path();
  install_signal_handlers();

  if (opt.daemon) {
    if (!opt.wave_kind.empty()) return fail(kExitUsage, "--daemon takes no waveform");
    return run_daemon(opt);
  }
  if (opt.wave_kind.empty()) {
    return fail(kExitUsage, "give a waveform: --sine FREQ, --square FREQ, --step or --hold");
  }
  if (!opt.local) {
    const int fd = connect_daemon(opt.socket_path);
    if (fd >= 0) return run_client(fd, opt);
  }
  return run_local(opt);
}
