#pragma once
// omni_ctl's daemon protocol (docs/omni_ctl-protocol.md) without sockets: the framing of request
// lines, the parsing and checking of one request, and the writing of reply lines. Kept apart from
// the server so that tests/fuzz/fuzz_protocol.cpp compiles it alone.
//
// The two promises the server builds on:
//   - parse_request() never throws: any byte string gives a Request or an error text;
//   - to_line() never throws: any JSON value, whatever bytes its strings hold, becomes one valid
//     UTF-8 line (bytes that are not UTF-8 become U+FFFD), so no reply can abort the daemon.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "alphainv/device/control_loop.hpp"

namespace omni_ctl {

/// The name of a waveform in the daemon protocol and the messages: "sine", "square", "step",
/// "hold".
const char* wave_name(alphainv::rt::WaveKind kind);
/// The waveform `name` names (the inverse of wave_name()), or none.
std::optional<alphainv::rt::WaveKind> wave_from_name(std::string_view name);
/// True for the waveforms that have a frequency (sine, square).
bool is_periodic(alphainv::rt::WaveKind kind);

namespace protocol {

using json = nlohmann::json;

constexpr std::size_t kMaxMessageBytes = 4096;  ///< one request line, newline excluded

/// True when `text` is well-formed UTF-8 (no overlong forms, surrogates or code points > U+10FFFF).
bool is_valid_utf8(std::string_view text) noexcept;
/// `text` with every byte that does not belong to a well-formed UTF-8 sequence replaced by U+FFFD
/// (valid text is returned unchanged).
std::string sanitize_utf8(std::string_view text);

/// `j` as one line: compact JSON and "\n". Never throws; strings that are not UTF-8 are repaired
/// (U+FFFD), so the line is valid UTF-8 whatever `j` holds.
std::string to_line(const json& j) noexcept;
/// {"ok":false,"error":message}, the message sanitised.
json error_reply(std::string_view message);

/// Splits a byte stream into request lines of at most kMaxMessageBytes.
class LineFramer {
 public:
  enum class Next {
    kNone,      ///< no whole line buffered
    kLine,      ///< `line` holds the next line (newline removed)
    kTooLong,   ///< a whole line longer than the limit was dropped; `line` is empty
    kOverflow,  ///< more than the limit buffered without a newline: the peer must be dropped
  };
  void append(const char* data, std::size_t n) { buffer_.append(data, n); }
  /// The next line, if any.
  Next next(std::string& line, std::size_t& length);

 private:
  std::string buffer_;
};

/// What the daemon knows when it checks a request.
struct RequestLimits {
  double kp_max = 10.0;  ///< largest gain a `gains` request may set [V/rad]
};

/// One request, checked.
struct Request {
  enum class Cmd { kStatus, kGains, kStream, kStop, kRun };
  Cmd cmd = Cmd::kStatus;
  double kp = 0.0;       ///< gains [V/rad]
  double rate_hz = 0.0;  ///< stream [Hz]
  // run:
  alphainv::rt::WaveKind wave = alphainv::rt::WaveKind::kHold;
  double freq_hz = 0.0;         ///< sine, square [Hz]
  double amplitude_rad = 0.07;  ///< [rad]
  double duration_s = 10.0;     ///< [s]
  std::string record;           ///< absolute folder, or empty
  bool force = false;           ///< record: replace the dataset the folder holds
  std::string command_line;     ///< sanitised; empty when the request had none
};

/// The result of parse_request(): a request, or the error text to reply with.
struct ParsedRequest {
  std::optional<Request> request;
  std::string error;  ///< names the field, e.g. "'kp': expected 0 <= value <= 10, got 50"
};

/// Why the reference of waveform `wave` (amplitude `amplitude_rad`), centred as the loop centres
/// it on the current angle `theta_rad`, would leave |θ| ≤ `theta_limit_rad`; empty when it stays
/// within (hold: θ; step: θ + A; sine, square: θ ± A). Names the field amplitude_rad.
std::string reference_beyond_limit(alphainv::rt::WaveKind wave, double amplitude_rad,
                                   double theta_rad, double theta_limit_rad);

/// Parses and checks one request line (docs/omni_ctl-protocol.md, "Requests"). Never throws.
ParsedRequest parse_request(std::string_view line, const RequestLimits& limits) noexcept;

}  // namespace protocol
}  // namespace omni_ctl
