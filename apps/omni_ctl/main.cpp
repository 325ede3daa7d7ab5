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
#include <cstdio>
#include <string>

#include "alphainv/device/emergency_stop.hpp"
#include "alphainv/device/loop_runner.hpp"
#include "alphainv/error.hpp"
#include "alphainv/model/effects.hpp"
#include "apps/common/units.hpp"
#include "options.hpp"
#include "protocol.hpp"
#include "socket.hpp"

namespace {

using namespace alphainv;
using namespace omni_ctl;

/// The one process-wide variable: set by SIGINT/SIGTERM, which end a run or the daemon. A signal
/// handler can reach nothing but a global and may only store to a lock-free atomic
/// (async-signal-safe); everything else is handed a reference to this flag.
std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

extern "C" void on_signal(int) { g_stop.store(true); }

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

ExitCode fail(ExitCode code, const std::string& message) {
  std::fprintf(stderr, "omni_ctl: %s\n", message.c_str());
  return code;
}

/// The command line as text for dataset.json and the daemon: bytes that are not UTF-8 (a Latin-1
/// path) become U+FFFD, so the JSON that carries it can always be written.
std::string command_line(int argc, char** argv) {
  std::string out = "omni_ctl";
  for (int i = 1; i < argc; ++i) out += std::string(" ") + argv[i];
  return protocol::sanitize_utf8(out);
}

/// The loop options (docs/omni_ctl.md) a daemon runs with its own values of.
constexpr const char* kLoopOptions[] = {"--max-command", "--max-slew",    "--theta-limit",
                                        "--stall-periods", "--max-missed", "--sim-fault",
                                        "--device",      "--model",       "--rt-priority",
                                        "--no-mlock",    "--compensate",  "--compensate-damping",
                                        "--sim-effect",
                                        "--sim-push",    "--sim-noise",   "--sim-seed"};

ExitCode run_local(const Options& opt, const std::atomic<bool>& stop) {
  LoopSetup setup;
  try {
    setup = make_loop_setup(opt);
  } catch (const Error& e) {
    return fail(ExitCode::kBadInput, e.what());
  }
  if (!setup.model_note.empty()) {
    std::fprintf(stderr, "omni_ctl: note: %s\n", setup.model_note.c_str());
  }
  device::Transport& transport = *setup.transport;
  try {
    transport.open();
  } catch (const Error& e) {
    return fail(ExitCode::kDevice, e.what());
  }

  device::LoopRunnerOptions ro;
  ro.exit_when_idle = true;
  std::unique_ptr<device::LoopRunner> runner;
  try {
    runner = std::make_unique<device::LoopRunner>(transport, setup.config, ro);
  } catch (const Error& e) {
    transport.close();
    return fail(ExitCode::kBadInput, e.what());
  }
  const device::LoopCommand run = make_run_command(opt, 1);
  const bool recorded = !opt.record_dir.empty();
  if (recorded) {
    try {  // the folder is checked (new or --force, writable) before the motor moves
      runner->add_recording(1, make_recording(opt, run, setup));
    } catch (const Error& e) {
      runner.reset();
      transport.close();
      return fail(ExitCode::kBadInput, std::string("--record: ") + e.what());
    }
  }
  (void)runner->post(run);

  const device::RealtimeSetup rt_setup = device::request_realtime(opt.rt_priority, !opt.no_mlock);
  for (const auto& w : rt_setup.warnings)
    std::fprintf(stderr, "omni_ctl: warning: %s\n", w.c_str());
  std::fprintf(stderr, "omni_ctl: %s on %s, kp %g, %s\n", wave_name(run.wave.kind),
               transport.describe().c_str(), opt.kp, rt_setup.describe().c_str());

  const device::LoopOutcome outcome = runner->run(stop);
  device::RunResult result;
  const bool have_result = runner->wait_run(1, 30.0, result);
  transport.close();

  std::fprintf(stderr, "omni_ctl: %s", outcome.full_report().c_str());
  if (recorded) {
    std::fprintf(stderr, "omni_ctl: %s\n",
                 have_result ? result.brief_report().c_str()
                             : ("the recording did not finish in time: " + opt.record_dir).c_str());
  }
  if (!outcome.usable()) return ExitCode::kFailed;
  if (recorded && (!have_result || !result.usable())) return ExitCode::kRecording;
  return ExitCode::kOk;
}

/// Runs `opt` on the daemon at its socket when one listens there and can be trusted, else here.
ExitCode run_here_or_on_daemon(const Options& opt, const std::atomic<bool>& stop) {
  if (opt.local) return run_local(opt, stop);
  const Connection daemon = connect_daemon(opt.socket_path);
  if (!daemon.error.empty()) return fail(ExitCode::kDevice, daemon.error);
  if (daemon.fd < 0) return run_local(opt, stop);
  if (!protocol::is_valid_utf8(opt.record_dir)) {
    close(daemon.fd);
    return fail(ExitCode::kBadInput,
                "--record: the path is not valid UTF-8, which the daemon protocol cannot carry; "
                "use a UTF-8 path, or --local to record here");
  }
  return run_client(daemon.fd, opt, stop);
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
  app.add_option("--record", opt.record_dir,
                 "write the run as a dataset (alphainv-dataset/1) into this new or empty folder");
  app.add_flag("--force", opt.force_record, "with --record: replace the dataset the folder holds");
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
  // Compensation and the virtual plant (docs/compensation.md).
  app.add_option("--compensate", opt.compensate,
                 "add the model's compensation to the P law: effects (cancel its torque effects, "
                 "invert its deadzone), feedforward (invert the alpha-model along the reference), "
                 "all")
      ->check(CLI::IsMember({"none", "effects", "feedforward", "all"}));
  app.add_option("--compensate-damping", opt.compensate_damping,
                 "with --compensate effects: the fraction (0 <= k < 1) of the alpha-model's damping "
                 "C*theta_dot cancelled too, for free motion (transparency); 0: none")
      ->check(CLI::Range(0.0, 0.99));
  app.add_option("--sim-effect", opt.sim_effects,
                 "an effect of --device sim's plant, NAME:PARAM=VALUE[,PARAM=VALUE] (repeatable), "
                 "e.g. coulomb_friction:coulomb_v=0.02; names: " + effect_names_text());
  app.add_option("--sim-push", opt.sim_push,
                 "an external torque on --device sim's joint: ramp:RATE[,start=S][,max=V] or "
                 "constant:V [V/s, V, s]");
  app.add_option("--sim-noise", opt.sim_noise_rad,
                 "Gaussian noise on --device sim's measured angle, before the encoder step [rad]")
      ->check(CLI::Range(0.0, 0.01));
  app.add_option("--sim-seed", opt.sim_seed, "seed of --sim-noise's generator")
      ->capture_default_str();
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
      opt.wave = rt::WaveKind::kSine;
      opt.freq_hz = apps::parse_frequency_hz(sine, "--sine");
    } else if (!square.empty()) {
      opt.wave = rt::WaveKind::kSquare;
      opt.freq_hz = apps::parse_frequency_hz(square, "--square");
    } else if (step) {
      opt.wave = rt::WaveKind::kStep;
    } else if (hold) {
      opt.wave = rt::WaveKind::kHold;
    }
    if (!duration.empty()) opt.duration_s = apps::parse_duration_s(duration, "--duration");
    if (opt.freq_hz > 100.0)
      throw CLI::ValidationError("--sine/--square: expected a frequency up to 100 Hz");
    for (const char* name : kLoopOptions) {
      if (app.count(name) > 0) opt.loop_options_given.emplace_back(name);
    }
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "omni_ctl: %s\nRun 'omni_ctl --help' for usage.\n", e.what());
    return apps::exit_status(ExitCode::kUsage);
  } catch (const Error& e) {
    std::fprintf(stderr, "omni_ctl: %s\nRun 'omni_ctl --help' for usage.\n",
                 apps::option_error(e).c_str());
    return apps::exit_status(ExitCode::kUsage);
  }
  if (opt.joint != "yaw") {
    return apps::exit_status(
        fail(ExitCode::kUsage, "--joint: only 'yaw' is supported, got '" + opt.joint + "'"));
  }
  if (opt.socket_path.empty()) opt.socket_path = default_socket_path();
  install_signal_handlers();
  device::install_crash_handlers();  // a crash while the loop runs zeroes the motor first

  ExitCode code = ExitCode::kOk;
  if (opt.daemon) {
    code = opt.wave ? fail(ExitCode::kUsage, "--daemon takes no waveform") : run_daemon(opt, g_stop);
  } else if (!opt.wave) {
    code = fail(ExitCode::kUsage, "give a waveform: --sine FREQ, --square FREQ, --step or --hold");
  } else {
    code = run_here_or_on_daemon(opt, g_stop);
  }
  return apps::exit_status(code);
}
