// Tests of include/alphainv/simulate/known_inputs.hpp: a run's disturbance_v, torque_enable and
// v_comp columns held between samples, and what a column of the wrong length says.
#include "alphainv/simulate/known_inputs.hpp"

#include <string>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv {
namespace {

RunData run_with(bool disturbance, bool enable) {
  RunData d;
  d.t = {0.0, 0.1, 0.2, 0.3};
  d.r = d.theta = d.v = {0.0, 0.0, 0.0, 0.0};
  if (disturbance) d.extra_columns["disturbance_v"] = {0.0, 0.5, -0.25, 0.0};
  if (enable) d.extra_columns["torque_enable"] = {1.0, 1.0, 0.0, 1.0};
  return d;
}

TEST(KnownInputs, ARunWithoutTheColumnsHasNone) {
  const RunData d = run_with(false, false);
  const KnownInputSeries k = KnownInputSeries::of_run(d);
  EXPECT_TRUE(k.empty());
  EXPECT_FALSE(k.has_torque_off());
  EXPECT_EQ(k.at(0.15).disturbance_v, 0.0);
  EXPECT_TRUE(k.at(0.15).torque_enabled);
  EXPECT_TRUE(KnownInputSeries().empty());
}

TEST(KnownInputs, ColumnsAreHeldFromOneSampleToTheNext) {
  const RunData d = run_with(true, true);
  const KnownInputSeries k = KnownInputSeries::of_run(d);
  ASSERT_FALSE(k.empty());
  EXPECT_TRUE(k.has_disturbance());
  EXPECT_TRUE(k.has_torque_off());
  EXPECT_EQ(k.at_sample(1).disturbance_v, 0.5);
  EXPECT_EQ(k.at(0.1).disturbance_v, 0.5);     // on a sample: that sample's
  EXPECT_EQ(k.at(0.1999).disturbance_v, 0.5);  // held until the next
  EXPECT_EQ(k.at(0.2).disturbance_v, -0.25);
  EXPECT_FALSE(k.at(0.25).torque_enabled);
  EXPECT_TRUE(k.at(0.3).torque_enabled);
  EXPECT_EQ(k.at(-1.0).disturbance_v, 0.0);  // before the first sample: the first's
  EXPECT_EQ(k.at(9.0).disturbance_v, 0.0);   // after the last: the last's
  EXPECT_EQ(k.at_sample(99).disturbance_v, 0.0);
  EXPECT_FALSE(k.has_command_offset());
  EXPECT_EQ(k.at(0.15).command_offset_v, 0.0);
}

TEST(KnownInputs, ACompensatedRunsVCompIsAKnownCommandOffset) {
  RunData d = run_with(false, false);
  d.extra_columns["v_comp"] = {0.01, -0.02, 0.03, 0.0};
  const KnownInputSeries k = KnownInputSeries::of_run(d);
  ASSERT_FALSE(k.empty());
  EXPECT_TRUE(k.has_command_offset());
  EXPECT_FALSE(k.has_disturbance());
  EXPECT_EQ(k.at(0.05).command_offset_v, 0.01);
  EXPECT_EQ(k.at(0.1999).command_offset_v, -0.02);
  EXPECT_EQ(k.at(0.2).command_offset_v, 0.03);
  EXPECT_EQ(k.at(0.2).disturbance_v, 0.0);  // a command, not a torque on the joint
  EXPECT_TRUE(k.at(0.2).torque_enabled);
  d.extra_columns["v_comp"].push_back(1.0);
  try {
    (void)KnownInputSeries::of_run(d);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "v_comp");
  }
}

TEST(KnownInputs, AColumnOfTheWrongLengthNamesIt) {
  RunData d = run_with(true, false);
  d.extra_columns["disturbance_v"].pop_back();
  try {
    (void)KnownInputSeries::of_run(d);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "disturbance_v");
    EXPECT_NE(std::string(e.what()).find("expected 4 samples"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace alphainv
