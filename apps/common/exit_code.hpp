#pragma once
/// \file apps/common/exit_code.hpp
/// The exit status of omni_fit, omni_gen and omni_ctl: one meaning per value for all three
/// (their --help footers, docs/omni_ctl.md).

namespace alphainv::apps {

/// What a program's exit status says.
enum class ExitCode : int {
  kOk = 0,        ///< done (omni_ctl: also after SIGINT/SIGTERM, the motor zeroed and disabled)
  kUsage = 1,     ///< the command line is wrong (an unknown option, a bad or missing value)
  kBadInput = 2,  ///< a value, file or key was rejected (the message names it)
  /// The work itself failed: nothing could be fitted (omni_fit fit, diagnose), a simulation
  /// failed (omni_fit simulate, demo), a safety fault stopped the loop (omni_ctl; the motor
  /// command zeroed and the motor disabled).
  kFailed = 3,
  kDevice = 4,     ///< omni_ctl: the device or the daemon could not be opened or reached
  kRecording = 5,  ///< omni_ctl: the loop ended cleanly but the recording was not written
};

/// The process exit status of `code` (what main() returns).
constexpr int exit_status(ExitCode code) noexcept { return static_cast<int>(code); }

}  // namespace alphainv::apps
