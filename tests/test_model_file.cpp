#include "alphainv/model_file.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv {
namespace {

ModelFile sample_model() {
  ModelFile m;
  m.tool_version = "alphainv test";
  m.dataset_hash = "0123456789abcdef";
  m.controller.kp = 2.0;
  m.has_inertia_model = true;
  m.linear = paper_linear_model();
  m.linear_se = {1e-4, 2e-4, 3e-4, 4e-4, 0.01, std::nan("")};
  m.poses.push_back({60.08, 87.0, 6.242, 229.04});
  m.poses.push_back({std::nullopt, std::nullopt, 5.0, 200.0});
  m.has_alpha_model = true;
  m.alpha = paper_alpha_model();
  m.c_n1_se[0] = 0.5;
  m.notes = {"a note"};
  return m;
}

TEST(ModelFile, RoundTripsEveryParameter) {
  const ModelFile m = sample_model();
  const ModelFile back = parse_model_file(format_model_file(m), "model.json");
  EXPECT_EQ(back.dataset_hash, m.dataset_hash);
  EXPECT_EQ(back.controller.kp, 2.0);
  EXPECT_FALSE(back.controller.has_limit());
  ASSERT_TRUE(back.has_inertia_model);
  EXPECT_EQ(back.linear.inertia.i3, m.linear.inertia.i3);
  EXPECT_EQ(back.linear.c0_bar, m.linear.c0_bar);
  EXPECT_EQ(back.linear_se[4], 0.01);
  EXPECT_TRUE(std::isnan(back.linear_se[5]));
  ASSERT_EQ(back.poses.size(), 2u);
  EXPECT_FALSE(back.poses[1].gamma1_deg.has_value());
  ASSERT_TRUE(back.has_alpha_model);
  EXPECT_EQ(back.alpha.n_breakpoints, 4u);
  for (std::size_t k = 0; k < 4; ++k) EXPECT_EQ(back.alpha.c_n1[k], m.alpha.c_n1[k]);
  EXPECT_EQ(back.alpha.beta_n1[1], m.alpha.beta_n1[1]);
  EXPECT_EQ(back.notes.at(0), "a note");
}

TEST(ModelFile, WritesAtomicallyAndReads) {
  const auto dir = std::filesystem::temp_directory_path() / "alphainv_test_model_file";
  std::filesystem::create_directories(dir);
  write_model_file(dir / "model.json", sample_model());
  EXPECT_FALSE(std::filesystem::exists(dir / "model.json.tmp"));
  EXPECT_EQ(read_model_file(dir / "model.json").alpha.c_n1[3], 61.733);
  std::filesystem::remove_all(dir);
}

void expect_error(const std::string& text, const std::string& needle) {
  try {
    parse_model_file(text, "bad.json");
    ADD_FAILURE() << "no error for " << text;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(ModelFile, BadInputNamesFileAndKey) {
  expect_error("{", "malformed JSON");
  expect_error("[]", "JSON object");
  expect_error(R"({"schema": "other/9"})", "schema");
  expect_error(R"({"schema": "alphainv-model/1"})", "controller");
  const std::string ctl = R"("controller": {"kp": 2, "ki": 0, "kd": 0, "v_limit": null})";
  expect_error(R"({"schema": "alphainv-model/1", "controller": {"kp": "x", "ki": 0, "kd": 0, "v_limit": null}})",
               "controller.kp");
  expect_error(R"({"schema": "alphainv-model/1", )" + ctl +
                   R"(, "alpha_model": {"breakpoints": [0, 1], "C_n1": [1], "beta_alpha": [0, 1], "beta_n1": [1, 1]}})",
               "alpha_model.C_n1");
  expect_error(R"({"schema": "alphainv-model/1", )" + ctl +
                   R"(, "alpha_model": {"breakpoints": [1, 0], "C_n1": [1, 1], "beta_alpha": [0, 1], "beta_n1": [1, 1]}})",
               "alpha_model");
  EXPECT_THROW(read_model_file("/nonexistent/model.json"), Error);
}

}  // namespace
}  // namespace alphainv
