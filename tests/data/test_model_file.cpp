#include "alphainv/data/model_file.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

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
  // Only model.json is left: no temporary file of the atomic writer (".model.json.tmp.<pid>.<n>").
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    ++files;
    EXPECT_EQ(entry.path().filename(), "model.json");
  }
  EXPECT_EQ(files, 1u);
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

ModelFile model_with_effects() {
  ModelFile m = sample_model();
  m.effects.coulomb_v = 0.05;
  m.effects.coulomb_smoothing_rad_s = 0.02;
  m.effects.offset_v = -0.03;
  m.effects.gravity_v = 0.2;
  m.effects.gravity_theta0_rad = 0.4;
  m.effects.cogging_v = 0.01;
  m.effects.cogging_period_rad = 0.1;
  m.effects.cogging_phase_rad = 1.5;
  m.effects.delay_s = 0.004;
  m.effects.saturation_v = 1.2;
  m.effects.deadzone_v = 0.02;
  m.loop_period_s = 1e-3;
  return m;
}

TEST(ModelFile, RoundTripsEffectsAndLoopPeriod) {
  const ModelFile m = model_with_effects();
  const std::string text = format_model_file(m);
  const ModelFile back = parse_model_file(text, "model.json");
  EXPECT_EQ(back.effects.coulomb_v, 0.05);
  EXPECT_EQ(back.effects.coulomb_smoothing_rad_s, 0.02);
  EXPECT_EQ(back.effects.offset_v, -0.03);
  EXPECT_EQ(back.effects.gravity_v, 0.2);
  EXPECT_EQ(back.effects.gravity_theta0_rad, 0.4);
  EXPECT_EQ(back.effects.cogging_v, 0.01);
  EXPECT_EQ(back.effects.cogging_period_rad, 0.1);
  EXPECT_EQ(back.effects.cogging_phase_rad, 1.5);
  EXPECT_EQ(back.effects.delay_s, 0.004);
  EXPECT_EQ(back.effects.saturation_v, 1.2);
  EXPECT_EQ(back.effects.deadzone_v, 0.02);
  EXPECT_EQ(back.loop_period_s, 1e-3);
  // The list holds the active effects in catalogue order, by catalogue name.
  const std::size_t c = text.find("\"coulomb_friction\""), o = text.find("\"offset_torque\""),
                    d = text.find("\"deadzone\"");
  ASSERT_NE(c, std::string::npos);
  ASSERT_NE(o, std::string::npos);
  ASSERT_NE(d, std::string::npos);
  EXPECT_LT(c, o);
  EXPECT_LT(o, d);
  EXPECT_NE(text.find("\"loop_period_s\": 0.001"), std::string::npos) << text;
}

TEST(ModelFile, NoEffectsWritesAnEmptyListAndReadsBackAllOff) {
  ModelFile m = sample_model();
  m.effects.offset_v = 0.1;  // one effect only: the others stay at their (off) defaults
  const ModelFile back = parse_model_file(format_model_file(m), "model.json");
  EXPECT_EQ(back.effects.offset_v, 0.1);
  EXPECT_EQ(active_effects(back.effects), std::vector<EffectKind>{EffectKind::kOffsetTorque});
  EXPECT_TRUE(std::isinf(back.effects.saturation_v));
  const std::string none = format_model_file(sample_model());
  EXPECT_NE(none.find("\"effects\": []"), std::string::npos) << none;
  EXPECT_TRUE(active_effects(parse_model_file(none, "model.json").effects).empty());
}

TEST(ModelFile, OldFileWithoutEffectsOrSimulationReads) {
  // A model.json as the first omni_fit wrote it: no "effects", no "simulation".
  const std::string old = R"({"schema": "alphainv-model/1", "tool_version": "alphainv 0.1.0",
    "controller": {"kp": 2, "ki": 0, "kd": 0, "derivative_on": "error", "v_limit": null},
    "inertia_model": null, "poses": [{"gamma1_deg": 65, "gamma2_deg": 90, "C_linear": 6.2,
    "beta_tilde_linear": 229}], "alpha_model": null, "notes": []})";
  const ModelFile m = parse_model_file(old, "old.json");
  EXPECT_TRUE(active_effects(m.effects).empty());
  EXPECT_EQ(m.effects.coulomb_smoothing_rad_s, Effects{}.coulomb_smoothing_rad_s);
  EXPECT_EQ(m.loop_period_s, 0.0);
  EXPECT_EQ(m.poses.at(0).c_linear, 6.2);
}

TEST(ModelFile, BadEffectsNameFileAndKeyPath) {
  const std::string head = R"({"schema": "alphainv-model/1", "controller": {"kp": 2, "ki": 0, "kd": 0, "v_limit": null}, )";
  auto with = [&](const std::string& tail) { return head + tail + "}"; };
  const std::string off = R"({"effect": "offset_torque", "parameters": {"offset_v": 0.1}})";
  expect_error(with(R"("effects": {"offset_v": 1})"), "'effects': expected an array");
  expect_error(with(R"("effects": [)" + off + R"(, {"effect": "friction", "parameters": {}}])"),
               "'effects[1].effect': unknown effect \"friction\"");
  expect_error(with(R"("effects": [)" + off + R"(, {"effect": "time_delay", "parameters": {"delay_s": -0.01}}])"),
               "'effects[1].parameters.delay_s'");
  expect_error(with(R"("effects": [{"effect": "time_delay", "parameters": {"delay_s": 2}}])"),
               "'effects[0].parameters.delay_s'");
  expect_error(with(R"("effects": [{"effect": "coulomb_friction", "parameters": {"coulomb_v": -0.1}}])"),
               "'effects[0].parameters.coulomb_v': expected a finite number >= 0");
  expect_error(with(R"("effects": [{"effect": "coulomb_friction", "parameters": {"coulomb_v": 0.1, "coulomb_smoothing_rad_s": 0}}])"),
               "'effects[0].parameters.coulomb_smoothing_rad_s'");
  // NaN has no JSON spelling: null and a string must be refused (an overflowing literal is
  // malformed JSON: no key to name, but still an alphainv::Error naming the file).
  expect_error(with(R"("effects": [{"effect": "gravity", "parameters": {"gravity_v": null, "gravity_theta0_rad": 0}}])"),
               "'effects[0].parameters.gravity_v': expected a number");
  expect_error(with(R"("effects": [{"effect": "gravity", "parameters": {"gravity_v": "NaN", "gravity_theta0_rad": 0}}])"),
               "'effects[0].parameters.gravity_v': expected a number");
  expect_error(with(R"("effects": [{"effect": "gravity", "parameters": {"gravity_v": 1e999, "gravity_theta0_rad": 0}}])"),
               "malformed JSON");
  expect_error(with(R"("effects": [{"effect": "gravity", "parameters": {"gravity_v": 0.2}}])"),
               "'effects[0].parameters.gravity_theta0_rad': missing key");
  expect_error(with(R"("effects": [{"effect": "cogging", "parameters": {"cogging_v": 0.1, "cogging_period_rad": 0, "cogging_phase_rad": 0}}])"),
               "'effects[0].parameters.cogging_period_rad'");
  expect_error(with(R"("effects": [{"effect": "saturation", "parameters": {"saturation_v": -1}}])"),
               "'effects[0].parameters.saturation_v'");
  expect_error(with(R"("effects": [{"effect": "deadzone", "parameters": {"deadzone_v": -0.1}}])"),
               "'effects[0].parameters.deadzone_v'");
  expect_error(with(R"("effects": [{"effect": "offset_torque", "parameters": {"offset_v": 0.1, "delay_s": 0}}])"),
               "'effects[0].parameters.delay_s': unknown parameter of offset_torque");
  expect_error(with(R"("effects": [{"effect": "offset_torque"}])"), "'effects[0].parameters'");
  expect_error(with(R"("effects": [{"parameters": {}}])"), "'effects[0].effect'");
  expect_error(with(R"("effects": [)" + off + "," + off + "]"), "'effects[1].effect': effect listed twice");
  expect_error(with(R"("simulation": {"loop_period_s": -0.001})"), "'simulation.loop_period_s'");
  expect_error(with(R"("simulation": {"loop_period_s": "1ms"})"), "'simulation.loop_period_s'");
}

TEST(ModelFile, RefusesToWriteWhatItWouldNotRead) {
  ModelFile m = sample_model();
  m.effects.delay_s = std::nan("");
  EXPECT_THROW(format_model_file(m), Error);
  m = sample_model();
  m.loop_period_s = -1.0;
  EXPECT_THROW(format_model_file(m), Error);
}

// Finding 13 of issue #13: a model with kp -2 or v_limit -1 simulated (theta 3.5e5 rad).
TEST(ModelFile, PhysicallyImpossibleValuesAreRefusedNamingTheKey) {
  std::string text = format_model_file(sample_model());
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const std::size_t at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return at == std::string::npos ? t : t.replace(at, from.size(), to);
  };
  expect_error(replaced("\"kp\": 2.0", "\"kp\": -2.0"), "'controller.kp': expected the P gain");
  expect_error(replaced("\"kp\": 2.0", "\"kp\": -1e-9"), "'controller.kp'");
  expect_error(replaced("\"v_limit\": null", "\"v_limit\": -1"),
               "'controller.v_limit': expected null (no limit) or a command limit > 0, found -1");
  expect_error(replaced("\"v_limit\": null", "\"v_limit\": 0"), "'controller.v_limit'");
  EXPECT_EQ(parse_model_file(replaced("\"v_limit\": null", "\"v_limit\": 1.5"), "m.json")
                .controller.v_limit, 1.5);
}

// Finding 4 of issue #13: a model file that is /dev/zero was read without bound (bad_alloc) and
// a FIFO hung `simulate`. Both are refused before reading, as are folders and huge files.
TEST(ModelFile, OnlyARegularFileOfBoundedSizeIsRead) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("alphainv_test_model_file_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  auto error_for = [](const fs::path& p) {
    try {
      read_model_file(p);
    } catch (const Error& e) {
      EXPECT_EQ(e.file(), p.string());
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_for("/dev/zero").find("expected a regular file"), std::string::npos);
  const fs::path fifo = dir / "model.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_NE(error_for(fifo).find("expected a regular file"), std::string::npos);  // no hang
  EXPECT_NE(error_for(dir).find("found a folder"), std::string::npos);
  EXPECT_NE(error_for(dir / "missing.json").find("does not exist"), std::string::npos);
  const fs::path big = dir / "big.json";
  { std::ofstream(big) << "{}"; }
  fs::resize_file(big, kMaxModelFileBytes + 1);
  EXPECT_NE(error_for(big).find("the limit is 16777216 bytes"), std::string::npos);
  const fs::path good = dir / "model.json";
  write_model_file(good, sample_model());
  EXPECT_EQ(read_model_file(good).controller.kp, 2.0);
  fs::remove_all(dir);
}

// An open-loop model (fitted on a dataset without a controller, issue #14: kp = ki = kd = 0) is
// written and read back; the check above refuses only what no gain can be.
TEST(ModelFile, AnOpenLoopModelRoundTrips) {
  ModelFile m = sample_model();
  m.controller = Controller{0.0};
  const ModelFile back = parse_model_file(format_model_file(m), "open_loop.json");
  EXPECT_EQ(back.controller.kp, 0.0);
  EXPECT_EQ(back.controller.ki, 0.0);
  EXPECT_EQ(back.controller.kd, 0.0);
}

// #14: several dataset folders fitted together: every folder's dataset.json is in the hash (in
// order, then the run files), and model.json lists the folders; one folder hashes as before.
TEST(ModelFile, TheHashCoversEveryDatasetFolder) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / ("alphainv_test_hash_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "a");
  fs::create_directories(root / "b");
  std::ofstream(root / "a" / "dataset.json") << "{\"a\": 1}";
  std::ofstream(root / "a" / "run.csv") << "t,r,theta,v\n0,0,0,0\n";
  std::ofstream(root / "b" / "dataset.json") << "{\"b\": 1}";
  std::ofstream(root / "b" / "run.csv") << "t,r,theta,v\n0,0,0,1\n";
  const std::vector<std::string> runs = {"run.csv", (root / "b" / "run.csv").string()};
  const std::string one = hash_dataset(root / "a", {"run.csv"});
  EXPECT_EQ(hash_dataset(std::vector<fs::path>{root / "a"}, {"run.csv"}), one);
  const std::string both = hash_dataset({root / "a", root / "b"}, runs);
  EXPECT_EQ(both.size(), 16u);
  EXPECT_NE(both, hash_dataset(root / "a", runs));  // b's dataset.json counts
  EXPECT_NE(both, hash_dataset({root / "b", root / "a"}, runs));  // in order
  std::ofstream(root / "b" / "dataset.json") << "{\"b\": 2}";
  EXPECT_NE(hash_dataset({root / "a", root / "b"}, runs), both);
  EXPECT_THROW(hash_dataset(std::vector<fs::path>{}, runs), Error);
  EXPECT_THROW(hash_dataset({root / "a", root / "missing"}, runs), Error);
  fs::remove_all(root);

  ModelFile m = sample_model();
  m.dataset_paths = {"/data/a", "/data/b"};
  const std::string text = format_model_file(m);
  EXPECT_NE(text.find(kDatasetHashCovers), std::string::npos);
  EXPECT_EQ(parse_model_file(text, "model.json").dataset_paths, m.dataset_paths);
  EXPECT_TRUE(parse_model_file(format_model_file(sample_model()), "m.json").dataset_paths.empty());
  std::string bad = text;
  bad.replace(bad.find("\"/data/a\""), 9, "7");
  try {
    (void)parse_model_file(bad, "model.json");
    ADD_FAILURE() << "a number among the paths was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.paths"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace alphainv

namespace alphainv {
namespace {

TEST(ModelFile, ADiscoveredTermListsOnlyItsNonZeroTermsAndReadsBack) {
  ModelFile m = sample_model();
  m.effects.discovered_sign_v = -0.0041;
  m.effects.discovered_stribeck_mid_v = -0.0025;
  m.effects.discovered_smoothing_rad_s = 0.015;
  m.effects.discovered_velocity_scale_rad_s = 1.5;
  m.effects.discovered_position_center_rad = 0.002;
  m.effects.discovered_position_scale_rad = 0.07;
  const std::string text = format_model_file(m);
  EXPECT_NE(text.find("\"discovered\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"discovered_sign_v\""), std::string::npos) << text;
  EXPECT_EQ(text.find("\"discovered_one_v\""), std::string::npos) << text;  // zero: left out
  EXPECT_NE(text.find("\"equation\": \"n = -0.0041 sigma - 0.0025 sigma exp(-(w/0.15)^2)"),
            std::string::npos)
      << text;
  const ModelFile back = parse_model_file(text, "model.json");
  for (const EffectParameter& p : effect_spec(EffectKind::kDiscovered))
    EXPECT_EQ(back.effects.*p.member, m.effects.*p.member) << p.name;
  // A bad scale names its key path.
  std::string bad = text;
  const std::string key = "\"discovered_velocity_scale_rad_s\": 1.5";
  ASSERT_NE(bad.find(key), std::string::npos) << text;
  bad.replace(bad.find(key), key.size(), "\"discovered_velocity_scale_rad_s\": -1");
  try {
    parse_model_file(bad, "m.json");
    ADD_FAILURE() << "accepted a negative velocity scale";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "effects[0].parameters.discovered_velocity_scale_rad_s");
  }
}

}  // namespace
}  // namespace alphainv
