#pragma once
// omni_ctl's settings, shared by the single-run mode, the daemon and the client, and what they
// build from them alike: the loop's setup, a run's command and its recording.
#include <atomic>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "alphainv/device/control_loop.hpp"
#include "alphainv/device/loop_runner.hpp"
#include "alphainv/device/transport.hpp"
#include "apps/common/exit_code.hpp"
#include "protocol.hpp"

namespace omni_ctl {

using alphainv::apps::ExitCode;  // docs/omni_ctl.md lists the codes

/// Everything the command line sets.
struct Options {
  std::string joint = "yaw";
  /// The run's waveform (--sine, --square, --step, --hold); none given: the daemon, or a usage
  /// error.
  std::optional<alphainv::rt::WaveKind> wave;
  double freq_hz = 0.0;         ///< sine, square [Hz]
  double amplitude_rad = 0.07;  ///< reference amplitude [rad]
  double kp = 2.0;              ///< P gain [V/rad]
  double duration_s = 10.0;     ///< run length [s]
  std::string record_dir;
  bool force_record = false;  // --force: record into a folder that holds a dataset, replacing it
  std::string model_path;
  std::string device = "hid";
  std::string sim_fault;
  alphainv::rt::SafetyLimits safety;
  int rt_priority = 80;
  bool no_mlock = false;
  bool daemon = false;
  bool local = false;  // never talk to a daemon
  std::string socket_path;
  double stream_hz = 0.0;  // client: print state lines at this rate
  std::string command_line;  ///< as typed, made valid UTF-8 (it goes into JSON)
  /// The loop options given on the command line (--max-command, --sim-fault, …): a client
  /// refuses to run on a daemon that cannot honour them.
  std::vector<std::string> loop_options_given;
  // Model-based compensation and the virtual plant's physics (docs/compensation.md).
  std::string compensate;                // --compensate effects|feedforward|all ("": none)
  double compensate_damping = 0.0;       // --compensate-damping: kappa, the model's damping cancelled
  std::vector<std::string> sim_effects;  // --sim-effect NAME:PARAM=VALUE[,...] (repeatable)
  std::string sim_push;                  // --sim-push ramp:RATE[,start=S][,max=V] | constant:V
  double sim_noise_rad = 0.0;            // --sim-noise: measurement noise sigma [rad]
  std::uint64_t sim_seed = 1;            // --sim-seed: its generator's seed
};

/// What the loop runs with, built the same way by the single-run mode and the daemon.
struct LoopSetup {
  alphainv::rt::ControlLoopConfig config;                     ///< model file loaded, limits applied
  std::unique_ptr<alphainv::device::Transport> transport;     ///< not opened
  std::string model_source;  ///< "paper (Tables 5-7)" or the model file
  std::string model_note;    ///< what the model file lacks and which effects it has, or empty
};
/// The loop setup of `opt`. Throws alphainv::Error naming the option or file.
LoopSetup make_loop_setup(const Options& opt);

/// The run command of `opt`'s waveform (which must be set).
alphainv::device::LoopCommand make_run_command(const Options& opt, std::uint32_t run_id);
/// The recording of `run` in opt.record_dir, with opt.command_line and `setup`'s device and model.
alphainv::device::RunRecording make_recording(const Options& opt,
                                              const alphainv::device::LoopCommand& run,
                                              const LoopSetup& setup);

/// The default socket path: $XDG_RUNTIME_DIR/alphainv/omni_ctl.sock, else /tmp/alphainv-$UID/….
std::string default_socket_path();
/// Runs the daemon (foreground) until `stop` turns true (a signal) or a fault; sets `stop` when
/// it ends by itself.
ExitCode run_daemon(const Options& opt, std::atomic<bool>& stop);
/// Sends `opt`'s run to the daemon at `fd` (connected, trusted) and waits for it. When `stop`
/// turns true (a signal) before the run was sent, nothing is sent and the client leaves; after,
/// it asks the daemon to stop the run and waits at most 3 s for the answer.
ExitCode run_client(int fd, const Options& opt, const std::atomic<bool>& stop);

}  // namespace omni_ctl
