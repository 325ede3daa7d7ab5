#pragma once
// omni_ctl's settings, shared by the single-run mode, the daemon and the client.
#include <cstdint>
#include <memory>
#include <string>

#include "alphainv/device/loop_runner.hpp"
#include "alphainv/device/transport.hpp"
#include "alphainv/device/control_loop.hpp"

namespace omni_ctl {

/// Exit codes (also in docs/omni_ctl.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 1,      ///< bad command line
  kExitBadInput = 2,   ///< a value or file was rejected (the message names it)
  kExitFault = 3,      ///< a safety fault stopped the loop (motor zeroed and disabled)
  kExitDevice = 4,     ///< the device (or the daemon) could not be opened / reached
  kExitRecording = 5,  ///< the loop ended cleanly but the recording could not be written
};

/// Everything the command line sets.
struct Options {
  std::string joint = "yaw";
  std::string wave_kind;  // "sine", "square", "step", "hold"
  double freq_hz = 0.0;
  double amplitude_rad = 0.07;
  double kp = 2.0;
  double duration_s = 10.0;
  std::string record_dir;
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
  std::string command_line;
};

/// The loop configuration for `opt` (model file loaded, limits applied). Throws alphainv::Error
/// naming the option or file. `model_source` receives "paper" or the file.
alphainv::rt::ControlLoopConfig make_loop_config(const Options& opt, std::string& model_source,
                                                 std::string& model_note);
/// The transport `opt.device` names (not opened). Throws alphainv::Error naming --device.
std::unique_ptr<alphainv::device::Transport> make_transport(const Options& opt);
/// The run command and recording of `opt`'s waveform.
alphainv::device::LoopCommand make_run_command(const Options& opt, std::uint32_t run_id);
/// The default socket path: $XDG_RUNTIME_DIR/alphainv/omni_ctl.sock, else /tmp/alphainv-$UID/….
std::string default_socket_path();
/// Runs the daemon (foreground). Returns the exit code.
int run_daemon(const Options& opt);
/// Sends `opt`'s run to the daemon at `fd` (connected) and waits for it. Returns the exit code.
int run_client(int fd, const Options& opt);
/// Connects to the daemon socket; −1 when there is none.
int connect_daemon(const std::string& path);

}  // namespace omni_ctl
