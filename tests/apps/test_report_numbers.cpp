// The numbers of the apps' reports and JSON (apps/common/report_numbers.hpp): finite values as
// the format says, missing and infinite ones marked.
#include "apps/common/report_numbers.hpp"

#include <gtest/gtest.h>

#include <limits>

using namespace alphainv::apps;

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

TEST(TableCell, FiniteValuesInTheFormat) {
  EXPECT_EQ(table_cell(0.0123456), "0.01235");  // default %.4g
  EXPECT_EQ(table_cell(12345.6), "1.235e+04");
  EXPECT_EQ(table_cell(-2.5), "-2.5");
  EXPECT_EQ(table_cell(0.0), "0");
  EXPECT_EQ(table_cell(3.14159, "%.2f"), "3.14");
  EXPECT_EQ(table_cell(87.0, "%.1f °"), "87.0 °");
}

TEST(TableCell, MissingAndInfiniteValuesAreMarked) {
  EXPECT_EQ(table_cell(kNaN), "–");
  EXPECT_EQ(table_cell(-kNaN, "%.2f"), "–");
  EXPECT_EQ(table_cell(kInf), "∞");
  EXPECT_EQ(table_cell(-kInf, "%.2f"), "−∞");
}

TEST(JsonNumber, NullWhenNotFinite) {
  EXPECT_EQ(json_number(0.25).dump(), "0.25");
  EXPECT_EQ(json_number(-1e-300).get<double>(), -1e-300);
  EXPECT_TRUE(json_number(kNaN).is_null());
  EXPECT_TRUE(json_number(kInf).is_null());
  EXPECT_TRUE(json_number(-kInf).is_null());
  EXPECT_EQ(nlohmann::json({{"rms", json_number(kNaN)}}).dump(), "{\"rms\":null}");
}
