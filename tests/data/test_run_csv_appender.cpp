// RunCsvAppender: the run CSV written as it grows. The header is on disk once it is made, each
// flush puts the rows added before it on disk (read back bit for bit by the format's reader),
// rows not flushed are not there, non-finite derived cells are written as nan (the reader drops
// that column, keeps the others), measured columns must be finite, t must increase.
#include "alphainv/data/run_csv_appender.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "alphainv/data/dataset.hpp"
#include "alphainv/error.hpp"
#include "support/files.hpp"

namespace alphainv {
namespace {

namespace fs = std::filesystem;

using test::slurp;

class Appender : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_temp_dir("appender",
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(Appender, EachFlushPutsTheRowsBeforeItOnDiskAndNoneAfter) {
  const fs::path csv = dir_ / "run.csv";
  RunCsvAppender out(csv, {"torque_enable", "alpha"});
  EXPECT_EQ(out.extra_columns(), (std::vector<std::string>{"alpha", "torque_enable"}));
  EXPECT_EQ(slurp(csv), "t,r,theta,v,alpha,torque_enable\n");  // the header is on disk at once
  const double a[] = {0.0, 0.1, 1.0 / 3.0, -0.0, 5e-324, 1.0};
  const double b[] = {0.001, 0.2, 2.0 / 3.0, 1e-300, 1e300, 0.0};
  out.add_row(a);
  out.flush();
  out.add_row(b);
  EXPECT_EQ(out.rows(), 2u);
  EXPECT_EQ(out.rows_flushed(), 1u);
  const RunData one = read_run_csv(csv);  // another reader sees the flushed row only
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one.theta[0], 1.0 / 3.0);
  EXPECT_EQ((*one.column("alpha"))[0], 5e-324);
  out.close();
  const RunData two = read_run_csv(csv);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two.theta[1], 2.0 / 3.0);
  EXPECT_EQ(two.v[1], 1e-300);
  EXPECT_EQ((*two.column("alpha"))[1], 1e300);
  EXPECT_EQ((*two.column("torque_enable"))[1], 0.0);
  EXPECT_TRUE(std::signbit(two.v[0]));  // -0 kept
}

TEST_F(Appender, NonFiniteDerivedCellsAreNanAndCostOnlyTheirColumn) {
  const fs::path csv = dir_ / "run.csv";
  RunCsvAppender out(csv, {"theta_pred", "gamma1"});
  const double rows[3][6] = {{0.0, 0.0, 0.1, 0.2, 1.0, 0.1},
                             {0.001, 0.0, 0.2, 0.3, 1.0, NAN},
                             {0.002, 0.0, 0.3, 0.4, 1.0, -INFINITY}};
  for (const auto& row : rows) out.add_row(row);
  EXPECT_EQ(out.non_finite_cells(1), 2u);  // theta_pred (columns by name: gamma1, theta_pred)
  out.close();
  EXPECT_NE(slurp(csv).find("0.001,0,0.2,0.3,1,nan\n0.002,0,0.3,0.4,1,nan\n"), std::string::npos);
  const RunData run = read_run_csv(csv);
  ASSERT_EQ(run.size(), 3u);
  EXPECT_EQ(run.column("theta_pred"), nullptr);
  EXPECT_EQ(run.ignored_columns, std::vector<std::string>{"theta_pred"});
  EXPECT_EQ(run.theta[2], 0.3);
  EXPECT_EQ((*run.column("gamma1"))[2], 1.0);
}

TEST_F(Appender, MeasuredColumnsMustBeFiniteAndTimeMustIncrease) {
  const fs::path csv = dir_ / "run.csv";
  RunCsvAppender out(csv, {"gamma1"});
  const double good[] = {0.0, 0.0, 0.1, 0.2, 1.0};
  out.add_row(good);
  const double bad_theta[] = {0.001, 0.0, NAN, 0.2, 1.0};
  const double bad_gamma[] = {0.001, 0.0, 0.1, 0.2, INFINITY};
  const double same_t[] = {0.0, 0.0, 0.1, 0.2, 1.0};
  try {
    out.add_row(bad_theta);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "theta");
    EXPECT_EQ(e.line(), 3);
    EXPECT_EQ(e.file(), csv.string());
  }
  try {
    out.add_row(bad_gamma);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "gamma1");
  }
  EXPECT_THROW(out.add_row(same_t), Error);
  EXPECT_EQ(out.rows(), 1u);
  EXPECT_THROW(RunCsvAppender(dir_ / "x.csv", {"t"}), Error);        // a required name
  EXPECT_THROW(RunCsvAppender(dir_ / "y.csv", {"a,b"}), Error);      // a comma
  EXPECT_THROW(RunCsvAppender(dir_ / "no" / "z.csv", {}), Error);    // no such folder
}

}  // namespace
}  // namespace alphainv
