// The apps' exit codes (apps/common/exit_code.hpp): the values the apps have always returned, and
// the ones docs/omni_ctl.md documents.
#include "apps/common/exit_code.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <utility>

using namespace alphainv::apps;

TEST(ExitCode, ValuesAreTheAppsOwn) {
  static_assert(exit_status(ExitCode::kOk) == 0);
  EXPECT_EQ(exit_status(ExitCode::kUsage), 1);
  EXPECT_EQ(exit_status(ExitCode::kBadInput), 2);
  EXPECT_EQ(exit_status(ExitCode::kFailed), 3);
  EXPECT_EQ(exit_status(ExitCode::kDevice), 4);
  EXPECT_EQ(exit_status(ExitCode::kRecording), 5);
}

TEST(ExitCode, OmniCtlsDocumentationListsTheSameValues) {
  std::ifstream f(std::string(ALPHAINV_SOURCE_DIR) + "/docs/omni_ctl.md");
  ASSERT_TRUE(f) << "docs/omni_ctl.md";
  std::stringstream text;
  text << f.rdbuf();
  std::string doc = text.str();
  const auto at = doc.find("Exit codes:");
  ASSERT_NE(at, std::string::npos);
  doc = doc.substr(at, doc.find("\n\n", at) - at);
  for (char& c : doc) c = c == '\n' ? ' ' : c;
  const std::pair<ExitCode, const char*> documented[] = {
      {ExitCode::kOk, "ok"},
      {ExitCode::kUsage, "usage"},
      {ExitCode::kBadInput, "bad input"},
      {ExitCode::kFailed, "safety fault"},
      {ExitCode::kDevice, "device or daemon unavailable"},
      {ExitCode::kRecording, "recording not written"},
  };
  for (const auto& [code, meaning] : documented) {
    const std::string item = std::to_string(exit_status(code)) + " " + meaning;
    EXPECT_NE(doc.find(item), std::string::npos) << item << " in: " << doc;
  }
}
