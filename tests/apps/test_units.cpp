// The apps' command-line values with units (apps/common/units.hpp): what they accept, and that a
// bad value names the option with the same message in every app.
#include "apps/common/units.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>

using namespace alphainv;
using namespace alphainv::apps;

TEST(CommandLineValues, ParseWithUnits) {
  EXPECT_EQ(parse_frequency_hz("3Hz", "--sine"), 3.0);
  EXPECT_EQ(parse_frequency_hz("0.25Hz", "--square"), 0.25);
  EXPECT_EQ(parse_frequency_hz("2.5 Hz", "--sine"), 2.5);
  EXPECT_EQ(parse_frequency_hz("3", "--sine"), 3.0);
  EXPECT_EQ(parse_frequency_hz("1kHz", "--rate"), 1000.0);
  EXPECT_EQ(parse_duration_s("8s", "--duration"), 8.0);
  EXPECT_EQ(parse_duration_s("500ms", "--duration"), 0.5);
  EXPECT_EQ(parse_duration_s("2", "--duration"), 2.0);
  EXPECT_EQ(parse_pose_deg("65,90", "--pose"), std::make_pair(65.0, 90.0));
  EXPECT_EQ(parse_pose_deg(" 60.08 , 87 ", "--pose"), std::make_pair(60.08, 87.0));
  // What omni_ctl's own parser took before it used this one: spaces around the unit, a bare
  // number in the option's unit.
  EXPECT_EQ(parse_frequency_hz("0.25 Hz ", "--square"), 0.25);
  EXPECT_EQ(parse_duration_s("10 s", "--duration"), 10.0);
  EXPECT_DOUBLE_EQ(parse_duration_s("250ms", "--duration"), 0.25);
}

TEST(CommandLineValues, BadValuesNameTheOption) {
  for (const char* bad :
       {"", "Hz", "3Hzz", "3 kg", "-3Hz", "0Hz", "nanHz", "infHz", "1e999Hz", "3Hz4", "three"}) {
    try {
      parse_frequency_hz(bad, "--sine");
      ADD_FAILURE() << "accepted \"" << bad << "\"";
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "--sine") << bad;
      EXPECT_NE(std::string(e.what()).find("Hz"), std::string::npos) << e.what();
    }
  }
  for (const char* bad : {"", "8min", "-1s", "0s", "s", "8 m s"}) {
    EXPECT_THROW(parse_duration_s(bad, "--duration"), Error) << bad;
  }
  for (const char* bad : {"", "65", "65,", ",90", "a,b", "65,90,1", "65;90", "nan,90"}) {
    EXPECT_THROW(parse_pose_deg(bad, "--pose"), Error) << bad;
  }
}

TEST(CommandLineValues, MessagesAsTheCommandLinePrintsThem) {
  const auto message = [](auto&& parse) {
    try {
      parse();
    } catch (const Error& e) {
      return option_error(e);
    }
    return std::string("accepted");
  };
  EXPECT_EQ(message([] { parse_frequency_hz("fastHz", "--sine"); }),
            "--sine: expected a frequency like 3Hz, 0.25Hz or 1kHz, got \"fastHz\"");
  EXPECT_EQ(message([] { parse_frequency_hz("0Hz", "--square"); }),
            "--square: expected a frequency > 0 Hz, got \"0Hz\"");
  EXPECT_EQ(message([] { parse_duration_s("8min", "--duration"); }),
            "--duration: expected a duration like 8s or 500ms, got \"8min\"");
  EXPECT_EQ(message([] { parse_duration_s("-1s", "--duration"); }),
            "--duration: expected a duration > 0, got \"-1s\"");
  EXPECT_EQ(message([] { parse_pose_deg("65;90", "--pose"); }),
            "--pose: expected two angles in degrees like 65,90, got \"65;90\"");
}
