// Tests of src/common/format.hpp: exact strings of each formatter, non-finite values, long
// outputs, and that shortest() reads back bit for bit.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <random>
#include <string>

#include "common/format.hpp"

namespace alphainv::common {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Format, PrintfIntoAString) {
  EXPECT_EQ(format("pose %zu: got %g rad", std::size_t{3}, 0.5), "pose 3: got 0.5 rad");
  EXPECT_EQ(format("%s|corr| with %s = %.4f", "", "I1", 0.98765), "|corr| with I1 = 0.9877");
  EXPECT_EQ(format("%+.1f", 2.26), "+2.3");
  EXPECT_EQ(format("%-6s|", "ab"), "ab    |");
  EXPECT_EQ(format("no arguments"), "no arguments");
  EXPECT_EQ(format("%s", ""), "");
}

TEST(Format, LongerThanTheStackBuffer) {
  const std::string long_word(1000, 'w');
  EXPECT_EQ(format("<%s>", long_word.c_str()), "<" + long_word + ">");
  EXPECT_EQ(fixed(1e300, 0).size(), 301u);
  EXPECT_EQ(fixed(1e300, 0).substr(0, 4), "1000");
}

TEST(Format, NumIsTheCoresSixSignificantDigits) {
  EXPECT_EQ(num(0.1), "0.1");
  EXPECT_EQ(num(2.0), "2");
  EXPECT_EQ(num(1234567.0), "1.23457e+06");
  EXPECT_EQ(num(0.000123456789), "0.000123457");
  EXPECT_EQ(num(-0.0), "-0");
  EXPECT_EQ(num(1000.0), format("%g", 1000.0));  // "%g" is "%.6g"
  EXPECT_EQ(num(3.14159265358979), alphainv::detail::num(3.14159265358979));
}

TEST(Format, NonFiniteAsPrintfWritesThem) {
  EXPECT_EQ(num(kNaN), "nan");
  EXPECT_EQ(num(kInf), "inf");
  EXPECT_EQ(num(-kInf), "-inf");
  EXPECT_EQ(sig(kInf, 3), "inf");
  EXPECT_EQ(fixed(-kInf, 2), "-inf");
  EXPECT_EQ(shortest(kNaN), "nan");
  EXPECT_EQ(shortest(-kInf), "-inf");
}

TEST(Format, SignificantDigits) {
  EXPECT_EQ(sig(3.14159265, 3), "3.14");
  EXPECT_EQ(sig(3.14159265, 1), "3");
  EXPECT_EQ(sig(2e-7, 2), "2e-07");
  EXPECT_EQ(sig(123456789.0, 10), "123456789");
  EXPECT_EQ(sig(0.1, 10), "0.1");
  EXPECT_EQ(sig(1.0 / 3.0, 10), "0.3333333333");
  EXPECT_EQ(sig(0.0, 4), "0");
}

TEST(Format, FixedDecimals) {
  EXPECT_EQ(fixed(2.5, 2), "2.50");
  EXPECT_EQ(fixed(60.08, 2), "60.08");
  EXPECT_EQ(fixed(-0.004, 2), "-0.00");
  EXPECT_EQ(fixed(1000.0, 0), "1000");
  EXPECT_EQ(fixed(1.0 / 3.0, 6), "0.333333");
}

TEST(Format, ShortestReadsBackExactly) {
  EXPECT_EQ(shortest(0.1), "0.1");
  EXPECT_EQ(shortest(1.0 / 3.0), "0.3333333333333333");
  EXPECT_EQ(shortest(1e300), "1e+300");
  EXPECT_EQ(shortest(5e-324), "5e-324");
  EXPECT_EQ(shortest(-2.0), "-2");
  std::string line = "t=";
  append_shortest(line, 0.25);
  EXPECT_EQ(line, "t=0.25");
  std::mt19937_64 rng(12);
  for (int k = 0; k < 10000; ++k) {
    std::uint64_t bits = rng();
    double x = 0.0;
    std::memcpy(&x, &bits, sizeof x);
    if (!std::isfinite(x)) continue;
    const std::string s = shortest(x);
    const double back = std::strtod(s.c_str(), nullptr);
    ASSERT_EQ(std::memcmp(&back, &x, sizeof x), 0) << s;
  }
}

}  // namespace
}  // namespace alphainv::common
