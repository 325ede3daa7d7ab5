// omni_ctl's protocol module (apps/omni_ctl/protocol.hpp) on its own: UTF-8 checking and repair
// against the Unicode table of well-formed sequences, reply lines that stay valid whatever they
// carry, the framing limits, every request field's check, and the angle-limit test of a run.
#include "protocol.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <string>

using namespace omni_ctl;
using namespace omni_ctl::protocol;
namespace rt = alphainv::rt;

TEST(OmniCtlProtocol, Utf8ValidityFollowsTheUnicodeTable) {
  // Unicode 15, table 3-7: the well-formed byte sequences.
  for (const std::string& ok : {std::string(""), std::string("abc"), std::string("caf\xc3\xa9"),
                               std::string("\xe2\x82\xac"), std::string("\xf0\x9f\x98\x80"),
                               std::string("\xf4\x8f\xbf\xbf"), std::string("\xed\x9f\xbf"),
                               std::string("\x00", 1)}) {
    EXPECT_TRUE(is_valid_utf8(ok)) << ok;
    EXPECT_EQ(sanitize_utf8(ok), ok);
  }
  const std::string fffd = "\xef\xbf\xbd";
  const std::pair<std::string, std::string> bad[] = {
      {"\xff", fffd},                                // never a UTF-8 byte
      {"\xc0\xaf", fffd + fffd},                     // overlong '/'
      {"\xe0\x80\xaf", fffd + fffd + fffd},          // overlong, 3 bytes
      {"\xed\xa0\x80", fffd + fffd + fffd},          // a surrogate, U+D800
      {"\xf4\x90\x80\x80", fffd + fffd + fffd + fffd},  // above U+10FFFF
      {"\xe2\x82", fffd + fffd},                     // truncated
      {"/x\xe9", "/x" + fffd},                       // a Latin-1 path
      {"a\xc3", "a" + fffd},                         // truncated at the end
  };
  for (const auto& [in, out] : bad) {
    EXPECT_FALSE(is_valid_utf8(in)) << in;
    EXPECT_EQ(sanitize_utf8(in), out) << in;
    EXPECT_TRUE(is_valid_utf8(sanitize_utf8(in)));
  }
}

TEST(OmniCtlProtocol, ReplyLinesAreOneValidUtf8LineWhateverTheyCarry) {
  const std::string raw = "\xff\n\"\\{\xc3";
  const std::string line = to_line({{"ok", false}, {"error", raw}, {raw, 1}});
  EXPECT_EQ(line.back(), '\n');
  EXPECT_EQ(line.find('\n'), line.size() - 1);  // the newline inside is escaped
  EXPECT_TRUE(is_valid_utf8(line));
  const json back = json::parse(line);
  EXPECT_EQ(back["error"], "\xef\xbf\xbd\n\"\\{\xef\xbf\xbd");
  EXPECT_EQ(error_reply(raw)["error"], "\xef\xbf\xbd\n\"\\{\xef\xbf\xbd");
  EXPECT_EQ(to_line({{"x", std::numeric_limits<double>::infinity()}}), "{\"x\":null}\n");
}

TEST(OmniCtlProtocol, TheFramerKeepsToTheLineLimit) {
  LineFramer f;
  std::string line;
  std::size_t length = 0;
  const std::string a = R"({"cmd":"status"})";
  f.append(a.data(), a.size());
  EXPECT_EQ(f.next(line, length), LineFramer::Next::kNone);
  f.append("\n", 1);
  ASSERT_EQ(f.next(line, length), LineFramer::Next::kLine);
  EXPECT_EQ(line, a);
  const std::string at_limit(kMaxMessageBytes, 'x');
  f.append(at_limit.data(), at_limit.size());
  f.append("\n", 1);
  ASSERT_EQ(f.next(line, length), LineFramer::Next::kLine);
  EXPECT_EQ(line.size(), kMaxMessageBytes);
  const std::string over(kMaxMessageBytes + 1, 'y');
  f.append(over.data(), over.size());
  f.append("\nz", 2);
  EXPECT_EQ(f.next(line, length), LineFramer::Next::kTooLong);
  EXPECT_EQ(length, kMaxMessageBytes + 1);
  EXPECT_EQ(f.next(line, length), LineFramer::Next::kNone);  // "z" waits for its newline
  f.append(over.data(), over.size());
  EXPECT_EQ(f.next(line, length), LineFramer::Next::kOverflow);
}

TEST(OmniCtlProtocol, EachRequestFieldIsCheckedAndNamed) {
  RequestLimits limits;
  limits.kp_max = 8.0;
  const std::pair<const char*, const char*> bad[] = {
      {"{bad", "malformed JSON"},
      {"[1]", "expected an object with a string \"cmd\""},
      {R"({"cmd":"gains","kp":9})", "'kp': expected 0.000000 <= value <= 8.000000, got 9"},
      {R"({"cmd":"gains","kp":"x"})", "'kp': expected a number"},
      {R"({"cmd":"stream","rate_hz":-1})", "'rate_hz'"},
      {R"({"cmd":"run","waveform":"sine"})", "'freq_hz': missing for sine"},
      {R"({"cmd":"run","waveform":"sine","freq_hz":0})", "'freq_hz'"},
      {R"({"cmd":"run","waveform":"step","duration_s":1e9})", "'duration_s'"},
      {R"({"cmd":"run","waveform":"step","record":"rel"})", "'record'"},
      {R"({"cmd":"run","waveform":"step","record":"/a\u0000b"})", "'record': expected a path without NUL"},
      {R"({"cmd":"run","waveform":"step","command_line":5})", "'command_line'"},
      {R"({"cmd":"jump"})", "unknown cmd 'jump'"},
  };
  for (const auto& [line, why] : bad) {
    const ParsedRequest p = parse_request(line, limits);
    EXPECT_FALSE(p.request) << line;
    EXPECT_NE(p.error.find(why), std::string::npos) << line << " -> " << p.error;
  }
  const ParsedRequest run = parse_request(
      R"({"cmd":"run","waveform":"square","freq_hz":0.25,"amplitude_rad":0.1,"duration_s":4,)"
      R"("record":"/tmp/r","command_line":"omni_ctl --square 0.25Hz"})",
      limits);
  ASSERT_TRUE(run.request) << run.error;
  EXPECT_EQ(run.request->cmd, Request::Cmd::kRun);
  EXPECT_EQ(run.request->wave, rt::WaveKind::kSquare);
  EXPECT_EQ(run.request->freq_hz, 0.25);
  EXPECT_EQ(run.request->amplitude_rad, 0.1);
  EXPECT_EQ(run.request->duration_s, 4.0);
  EXPECT_EQ(run.request->record, "/tmp/r");
  EXPECT_EQ(run.request->command_line, "omni_ctl --square 0.25Hz");
  const ParsedRequest gains = parse_request(R"({"cmd":"gains","kp":8})", limits);
  ASSERT_TRUE(gains.request);
  EXPECT_EQ(gains.request->kp, 8.0);
  const ParsedRequest step = parse_request(R"({"cmd":"run","waveform":"step"})", limits);
  ASSERT_TRUE(step.request);
  EXPECT_EQ(step.request->amplitude_rad, 0.07);  // the documented defaults
  EXPECT_EQ(step.request->duration_s, 10.0);
}

TEST(OmniCtlProtocol, AReferenceIsCheckedAgainstTheAngleLimitFromTheCurrentAngle) {
  using rt::WaveKind;
  // step: θ + A; sine and square: θ ± A; hold: θ.
  EXPECT_EQ(reference_beyond_limit(WaveKind::kStep, 0.5, 0.4, 1.0), "");
  EXPECT_NE(reference_beyond_limit(WaveKind::kStep, 0.7, 0.4, 1.0), "");
  EXPECT_EQ(reference_beyond_limit(WaveKind::kStep, 0.9, -0.5, 1.0), "");
  EXPECT_EQ(reference_beyond_limit(WaveKind::kSine, 0.5, 0.5, 1.0), "");
  EXPECT_NE(reference_beyond_limit(WaveKind::kSine, 0.5, -0.6, 1.0), "");  // reaches −1.1
  EXPECT_NE(reference_beyond_limit(WaveKind::kSquare, 0.31, 0.0, 0.3), "");
  EXPECT_EQ(reference_beyond_limit(WaveKind::kHold, 1.0, 0.2, 0.3), "");
  const std::string why = reference_beyond_limit(WaveKind::kSine, 0.5, -0.6, 1.0);
  EXPECT_NE(why.find("'amplitude_rad'"), std::string::npos) << why;
  EXPECT_NE(why.find("reach theta = -1.1 rad (from the current -0.6 rad)"), std::string::npos)
      << why;
}
