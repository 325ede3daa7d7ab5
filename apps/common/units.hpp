#pragma once
/// \file apps/common/units.hpp
/// Command-line values with units, as the apps take them: frequencies ("3Hz", "1kHz"),
/// durations ("8s", "500ms") and poses ("60.08,87" [deg]). A bad value throws alphainv::Error
/// whose field is the option, so the message names it.

#include <string>
#include <string_view>
#include <utility>

#include "alphainv/error.hpp"

namespace alphainv::apps {

/// "3Hz", "0.25 Hz", "3" → 3 [Hz]; "1kHz" → 1000. Finite, > 0. Throws alphainv::Error naming
/// `field`.
double parse_frequency_hz(std::string_view text, const std::string& field);
/// "8s", "500ms", "8" (seconds) → [s]. Finite, > 0. Throws alphainv::Error naming `field`.
double parse_duration_s(std::string_view text, const std::string& field);
/// "65,90" → (γ1, γ2) [deg]. Both finite. Throws alphainv::Error naming `field`.
std::pair<double, double> parse_pose_deg(std::string_view text, const std::string& field);

/// A parser's error as a command line reads it: "--sine: expected a frequency like 3Hz, …"
/// (the field, which is the option, then the message).
std::string option_error(const Error& error);

}  // namespace alphainv::apps
