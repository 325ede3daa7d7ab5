// libFuzzer target for omni_ctl's daemon protocol (apps/omni_ctl/protocol.hpp): the request
// parser and the reply writer the server is built on.
//
// The first input byte chooses what the rest is fed to (byte % 3):
//   0  parse_request          one line; a request must hold only checked values, an error must
//                             say something; the reply built from either must be a valid line
//   1  LineFramer             the bytes as a stream cut into chunks (sizes from the data), every
//                             line through parse_request and back out as a reply line
//   2  the reply writer       arbitrary bytes as string values and keys: to_line() must give one
//                             valid UTF-8 JSON line; sanitize_utf8 must agree with nlohmann's own
//                             UTF-8 check, be idempotent and leave valid text alone
// A valid reply line: ends in its only "\n", is valid UTF-8, parses back to a JSON object.
// Anything else, an exception out of parse_request/to_line, or a sanitizer report is a bug.
// Build and run: see tests/fuzz/CMakeLists.txt.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "protocol.hpp"

namespace {

namespace protocol = omni_ctl::protocol;
using protocol::json;

[[noreturn]] void bug(const char* what) {
  std::fprintf(stderr, "protocol invariant broken: %s\n", what);
  std::abort();
}

void check_line(const std::string& line) {
  if (line.empty() || line.back() != '\n') bug("reply line without its newline");
  if (line.find('\n') != line.size() - 1) bug("reply line with an inner newline");
  if (!protocol::is_valid_utf8(line)) bug("reply line is not UTF-8");
  json back;
  try {
    back = json::parse(line);
  } catch (const json::exception&) {
    bug("reply line does not parse");
  }
  if (!back.is_object()) bug("reply line is not an object");
}

bool in(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

/// The reply the server builds for `parsed`, as a line (checked).
void reply_to(const protocol::ParsedRequest& parsed, const protocol::RequestLimits& limits) {
  if (!parsed.request) {
    if (parsed.error.empty()) bug("an error without a message");
    check_line(protocol::to_line(protocol::error_reply(parsed.error)));
    return;
  }
  const protocol::Request& r = *parsed.request;
  using Cmd = protocol::Request::Cmd;
  if (r.cmd == Cmd::kGains && !in(r.kp, 0.0, limits.kp_max)) bug("kp out of range");
  if (r.cmd == Cmd::kStream && !in(r.rate_hz, 0.0, 1000.0)) bug("rate_hz out of range");
  if (r.cmd == Cmd::kRun) {
    if (!in(r.freq_hz, omni_ctl::is_periodic(r.wave) ? 1e-3 : 0.0, 100.0)) bug("freq_hz");
    if (!in(r.amplitude_rad, 0.0, 1.0)) bug("amplitude_rad out of range");
    if (!in(r.duration_s, 1e-3, 86400.0)) bug("duration_s out of range");
    if (!r.record.empty() && r.record[0] != '/') bug("record not absolute");
    if (r.record.find('\0') != std::string::npos) bug("record with a NUL");
    if (!protocol::is_valid_utf8(r.command_line)) bug("command_line not sanitised");
    // The run's reply and, at its end, the run_done event carry the request's strings.
    check_line(protocol::to_line({{"ok", true}, {"cmd", "run"}, {"run_id", 1}}));
    check_line(protocol::to_line({{"event", "run_done"},
                                  {"record", r.record},
                                  {"recording_error", "cannot write " + r.record},
                                  {"command_line", r.command_line}}));
    (void)protocol::reference_beyond_limit(r.wave, r.amplitude_rad, 0.0, 1.0);
  }
}

void one_request(std::string_view text) {
  protocol::RequestLimits limits;
  reply_to(protocol::parse_request(text, limits), limits);
}

void stream(std::string_view data) {
  protocol::LineFramer framer;
  protocol::RequestLimits limits;
  std::string line;
  std::size_t length = 0;
  std::size_t pos = 0;
  while (pos < data.size()) {
    const std::size_t chunk = 1 + static_cast<unsigned char>(data[pos]) % 64;
    ++pos;
    const std::size_t n = std::min(chunk, data.size() - pos);
    framer.append(data.data() + pos, n);
    pos += n;
    for (;;) {
      const auto next = framer.next(line, length);
      if (next == protocol::LineFramer::Next::kNone) {
        if (length > protocol::kMaxMessageBytes) bug("framer holds more than the limit");
        break;
      }
      if (next == protocol::LineFramer::Next::kLine) {
        if (line.size() > protocol::kMaxMessageBytes) bug("framer passed a line over the limit");
        if (line.find('\n') != std::string::npos) bug("framer line with a newline");
        reply_to(protocol::parse_request(line, limits), limits);
      } else if (next == protocol::LineFramer::Next::kTooLong) {
        if (length <= protocol::kMaxMessageBytes) bug("framer refused a line within the limit");
      } else {
        break;  // overflow: the server drops the client
      }
    }
  }
}

void writer(std::string_view text) {
  const std::string s(text);
  const std::string clean = protocol::sanitize_utf8(s);
  if (!protocol::is_valid_utf8(clean)) bug("sanitize_utf8 left invalid UTF-8");
  if (protocol::sanitize_utf8(clean) != clean) bug("sanitize_utf8 not idempotent");
  const bool valid = protocol::is_valid_utf8(s);
  if (valid && clean != s) bug("sanitize_utf8 changed valid text");
  bool strict_ok = true;  // nlohmann's strict writer: the second opinion on "valid UTF-8"
  try {
    (void)json(s).dump();
  } catch (const json::type_error&) {
    strict_ok = false;
  }
  if (strict_ok != valid) bug("is_valid_utf8 disagrees with nlohmann's UTF-8 check");
  check_line(protocol::to_line({{"ok", false}, {"error", s}, {s, s}, {"list", {s, 1.5, s}}}));
  check_line(protocol::to_line(protocol::error_reply(s)));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 3) {
    case 0:
      one_request(text);
      break;
    case 1:
      stream(text);
      break;
    default:
      writer(text);
      break;
  }
  return 0;
}
