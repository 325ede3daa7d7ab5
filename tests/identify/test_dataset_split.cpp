// Tests of include/alphainv/identify/dataset_split.hpp: datasets combined (files, controllers,
// units) and every K-th run per pose held out.
#include "alphainv/identify/dataset_split.hpp"

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "alphainv/error.hpp"

namespace alphainv {
namespace {

/// A dataset in `dir` with `n` runs at each of the poses (25, 70) and (45, 90) deg, alternating.
DatasetWithRuns part(const std::string& dir, std::size_t n, double kp) {
  DatasetWithRuns p;
  p.dataset.dir = dir;
  p.dataset.sample_rate_hz = 1000.0;
  for (std::size_t i = 0; i < 2 * n; ++i) {
    RunInfo r;
    r.file = "runs/r" + std::to_string(i) + ".csv";
    r.kind = "other";
    r.gamma1_deg = i % 2 == 0 ? 25.0 : 45.0;
    r.gamma2_deg = i % 2 == 0 ? 70.0 : 90.0;
    r.controller.kp = kp;
    p.dataset.runs.push_back(r);
    RunData d;
    d.t = {0.0, 1.0};
    d.r = d.theta = d.v = {static_cast<double>(i), 0.0};
    p.data.push_back(d);
  }
  return p;
}

TEST(DatasetSplit, CombinedDatasetsKeepEachRunsFileAndController) {
  const DatasetWithRuns one = combine_datasets({part("/a", 2, 2.0)});
  EXPECT_EQ(one.dataset.runs[0].file, "runs/r0.csv");  // one part: unchanged
  const DatasetWithRuns both = combine_datasets({part("/a", 2, 2.0), part("/b", 1, 3.0)});
  ASSERT_EQ(both.dataset.runs.size(), 6u);
  ASSERT_EQ(both.data.size(), 6u);
  EXPECT_EQ(both.dataset.dir, std::filesystem::path("/a"));
  EXPECT_EQ(both.dataset.runs[0].file, "/a/runs/r0.csv");
  EXPECT_EQ(both.dataset.runs[4].file, "/b/runs/r0.csv");
  EXPECT_EQ(both.dataset.runs[4].controller.kp, 3.0);
  EXPECT_EQ(both.data[5].r[0], 1.0);
  EXPECT_EQ(both.dataset.sample_rate_hz, 1000.0);
  DatasetWithRuns other_rate = part("/c", 1, 2.0);
  other_rate.dataset.sample_rate_hz = 200.0;
  EXPECT_FALSE(combine_datasets({part("/a", 1, 2.0), other_rate}).dataset.sample_rate_hz);
}

TEST(DatasetSplit, DifferentUnitsAreRefusedNamingTheField) {
  DatasetWithRuns metres = part("/m", 1, 2.0);
  metres.dataset.position_unit = "m";
  try {
    (void)combine_datasets({part("/a", 1, 2.0), metres});
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "position_unit");
    EXPECT_NE(std::string(e.what()).find("/m against /a"), std::string::npos) << e.what();
  }
  EXPECT_THROW(combine_datasets({}), Error);
}

TEST(DatasetSplit, EveryKthRunOfEachPoseIsHeldOut) {
  const DatasetWithRuns all = part("/a", 6, 2.0);  // 6 runs at each of 2 poses
  const HoldoutSplit s = holdout_every_kth_run_per_pose(all, 3);
  ASSERT_EQ(s.held_out.dataset.runs.size(), 4u);  // the 3rd and 6th of each pose
  ASSERT_EQ(s.fit.dataset.runs.size(), 8u);
  EXPECT_EQ(s.held_out.dataset.runs[0].file, "runs/r4.csv");  // pose 1's third run
  EXPECT_EQ(s.held_out.dataset.runs[1].file, "runs/r5.csv");  // pose 2's third run
  EXPECT_EQ(s.held_out.data[0].r[0], 4.0);
  EXPECT_EQ(s.held_out.dataset.sample_rate_hz, 1000.0);
  EXPECT_THROW(holdout_every_kth_run_per_pose(all, 1), Error);
  try {
    (void)holdout_every_kth_run_per_pose(all, 7);
    FAIL() << "no throw";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "holdout");
    EXPECT_NE(std::string(e.what()).find("nothing would be held out"), std::string::npos);
  }
}

}  // namespace
}  // namespace alphainv
