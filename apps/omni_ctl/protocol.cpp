// omni_ctl's daemon protocol: framing, request parsing, reply lines (protocol.hpp).
#include "protocol.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "alphainv/error.hpp"

namespace omni_ctl {

using alphainv::Error;
namespace rt = alphainv::rt;

const char* wave_name(rt::WaveKind kind) {
  switch (kind) {
    case rt::WaveKind::kSine:
      return "sine";
    case rt::WaveKind::kSquare:
      return "square";
    case rt::WaveKind::kStep:
      return "step";
    case rt::WaveKind::kHold:
      break;
  }
  return "hold";
}

std::optional<rt::WaveKind> wave_from_name(std::string_view name) {
  for (rt::WaveKind k :
       {rt::WaveKind::kSine, rt::WaveKind::kSquare, rt::WaveKind::kStep, rt::WaveKind::kHold}) {
    if (name == wave_name(k)) return k;
  }
  return std::nullopt;
}

bool is_periodic(rt::WaveKind kind) {
  return kind == rt::WaveKind::kSine || kind == rt::WaveKind::kSquare;
}

namespace protocol {
namespace {

/// Length of the well-formed UTF-8 sequence at s[i], or 0 when the byte there does not start one
/// (RFC 3629 / Unicode table 3-7: no overlong forms, no surrogates, nothing above U+10FFFF).
std::size_t utf8_sequence(std::string_view s, std::size_t i) noexcept {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  if (c < 0x80) return 1;
  std::size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (b(i + 1) < lo || b(i + 1) > hi) return 0;
  for (std::size_t k = 2; k < n; ++k) {
    if (b(i + k) < 0x80 || b(i + k) > 0xBF) return 0;
  }
  return n;
}

/// The number at `key` of `msg`, or `fallback` when absent; throws Error naming the key.
double number_field(const json& msg, const char* key, double fallback, double lo, double hi) {
  if (!msg.contains(key)) return fallback;
  const json& v = msg.at(key);
  if (!v.is_number()) throw Error("expected a number, got " + to_line(v).substr(0, 64), {}, 0, key);
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi) {
    throw Error("expected " + std::to_string(lo) + " <= value <= " + std::to_string(hi) + ", got " +
                    to_line(v).substr(0, 64),
                {}, 0, key);
  }
  return x;
}

Request parse_run(const json& msg, Request r) {
  if (!msg.contains("waveform") || !msg["waveform"].is_string()) {
    throw Error("expected one of sine, square, step, hold", {}, 0, "waveform");
  }
  const std::string& name = msg["waveform"].get_ref<const std::string&>();
  const auto wave = wave_from_name(name);
  if (!wave) {
    throw Error("expected one of sine, square, step, hold, got '" + name.substr(0, 64) + "'", {}, 0,
                "waveform");
  }
  r.wave = *wave;
  const bool periodic = is_periodic(r.wave);
  if (periodic && !msg.contains("freq_hz")) throw Error("missing for " + name, {}, 0, "freq_hz");
  r.freq_hz = number_field(msg, "freq_hz", 0.0, periodic ? 1e-3 : 0.0, 100.0);
  r.amplitude_rad = number_field(msg, "amplitude_rad", 0.07, 0.0, 1.0);
  r.duration_s = number_field(msg, "duration_s", 10.0, 1e-3, 86400.0);
  if (msg.contains("record")) {
    const json& rec = msg["record"];
    if (!rec.is_string() || rec.get_ref<const std::string&>().empty() ||
        rec.get_ref<const std::string&>()[0] != '/') {
      throw Error("expected an absolute folder path", {}, 0, "record");
    }
    r.record = rec.get<std::string>();
    if (r.record.find('\0') != std::string::npos) {
      throw Error("expected a path without NUL bytes", {}, 0, "record");
    }
  }
  if (msg.contains("force")) {
    if (!msg["force"].is_boolean()) throw Error("expected true or false", {}, 0, "force");
    r.force = msg["force"].get<bool>();
  }
  if (msg.contains("command_line")) {
    if (!msg["command_line"].is_string()) throw Error("expected a string", {}, 0, "command_line");
    r.command_line = sanitize_utf8(msg["command_line"].get_ref<const std::string&>());
  }
  return r;
}

Request parse_checked(std::string_view line, const RequestLimits& limits) {
  json msg;
  try {
    msg = json::parse(line);
  } catch (const json::exception& e) {
    throw Error(std::string("malformed JSON: ") + e.what());
  }
  if (!msg.is_object() || !msg.contains("cmd") || !msg["cmd"].is_string()) {
    throw Error("expected an object with a string \"cmd\"");
  }
  const std::string& cmd = msg["cmd"].get_ref<const std::string&>();
  Request r;
  if (cmd == "status") {
    r.cmd = Request::Cmd::kStatus;
  } else if (cmd == "gains") {
    r.cmd = Request::Cmd::kGains;
    if (!msg.contains("kp")) throw Error("missing", {}, 0, "kp");
    r.kp = number_field(msg, "kp", 0.0, 0.0, limits.kp_max);
  } else if (cmd == "stream") {
    r.cmd = Request::Cmd::kStream;
    r.rate_hz = number_field(msg, "rate_hz", 0.0, 0.0, 1000.0);
  } else if (cmd == "stop") {
    r.cmd = Request::Cmd::kStop;
  } else if (cmd == "run") {
    r.cmd = Request::Cmd::kRun;
    r = parse_run(msg, r);
  } else {
    throw Error("unknown cmd '" + cmd.substr(0, 64) +
                "' (known: run, gains, stream, stop, status)");
  }
  return r;
}

}  // namespace

bool is_valid_utf8(std::string_view text) noexcept {
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = utf8_sequence(text, i);
    if (n == 0) return false;
    i += n;
  }
  return true;
}

std::string sanitize_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const std::size_t n = utf8_sequence(text, i);
    if (n == 0) {
      out += "\xEF\xBF\xBD";  // U+FFFD REPLACEMENT CHARACTER
      ++i;
    } else {
      out.append(text.substr(i, n));
      i += n;
    }
  }
  return out;
}

std::string to_line(const json& j) noexcept {
  try {
    return j.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
  } catch (...) {  // only std::bad_alloc is left; a reply that cannot be built is not sent
    return "{\"ok\":false,\"error\":\"the reply could not be built\"}\n";
  }
}

json error_reply(std::string_view message) {
  return {{"ok", false}, {"error", sanitize_utf8(message)}};
}

LineFramer::Next LineFramer::next(std::string& line, std::size_t& length) {
  line.clear();
  length = 0;
  const std::size_t nl = buffer_.find('\n');
  if (nl == std::string::npos) {
    length = buffer_.size();
    if (buffer_.size() > kMaxMessageBytes) {
      buffer_.clear();
      return Next::kOverflow;
    }
    return Next::kNone;
  }
  length = nl;
  if (nl > kMaxMessageBytes) {
    buffer_.erase(0, nl + 1);
    return Next::kTooLong;
  }
  line.assign(buffer_, 0, nl);
  buffer_.erase(0, nl + 1);
  return Next::kLine;
}

std::string reference_beyond_limit(rt::WaveKind wave, double amplitude_rad, double theta_rad,
                                   double theta_limit_rad) {
  double lo = theta_rad, hi = theta_rad;
  if (wave == rt::WaveKind::kStep) hi += amplitude_rad;
  if (is_periodic(wave)) {
    lo -= amplitude_rad;
    hi += amplitude_rad;
  }
  const double reach = std::max(std::abs(lo), std::abs(hi));
  if (std::isfinite(reach) && reach <= theta_limit_rad) return {};
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "the %s's reference would reach theta = %.4g rad (from the current %.4g rad), "
                "beyond the angle limit +-%.4g rad (--theta-limit); the run was not started",
                wave_name(wave), std::abs(lo) > std::abs(hi) ? lo : hi, theta_rad, theta_limit_rad);
  return Error(buf, {}, 0, "amplitude_rad").what();
}

ParsedRequest parse_request(std::string_view line, const RequestLimits& limits) noexcept {
  ParsedRequest out;
  try {
    out.request = parse_checked(line, limits);
  } catch (const Error& e) {
    out.error = e.what();
  } catch (const std::exception& e) {  // nlohmann type errors, bad_alloc: still an answer
    out.error = std::string("bad request: ") + e.what();
  }
  return out;
}

}  // namespace protocol
}  // namespace omni_ctl
