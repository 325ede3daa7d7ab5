#include "alphainv/model/controller.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace alphainv {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(Controller, DefaultsAreTheVirtualOmniPLaw) {
  const Controller c;
  EXPECT_EQ(c.kp, 2.0);
  EXPECT_EQ(c.ki, 0.0);
  EXPECT_EQ(c.kd, 0.0);
  EXPECT_EQ(c.derivative_on, DerivativeOn::kError);
  EXPECT_EQ(c.v_limit, kInf);
  EXPECT_FALSE(c.has_limit());
}

TEST(Controller, ClampLimitsToPlusMinusVLimit) {
  Controller c;
  EXPECT_EQ(c.clamp(1e300), 1e300);  // no limit
  c.v_limit = 0.75;
  EXPECT_TRUE(c.has_limit());
  EXPECT_EQ(c.clamp(2.0), 0.75);
  EXPECT_EQ(c.clamp(-2.0), -0.75);
  EXPECT_EQ(c.clamp(0.5), 0.5);
  EXPECT_EQ(c.clamp(-0.75), -0.75);
}

TEST(Controller, EqualityComparesEveryField) {
  const Controller a;
  EXPECT_TRUE(a == Controller{});
  EXPECT_FALSE(a != Controller{});
  auto differs = [&](auto change) {
    Controller b;
    change(b);
    return a != b && !(a == b);
  };
  EXPECT_TRUE(differs([](Controller& b) { b.kp = 2.5; }));
  EXPECT_TRUE(differs([](Controller& b) { b.ki = 1e-9; }));
  EXPECT_TRUE(differs([](Controller& b) { b.kd = -0.1; }));
  EXPECT_TRUE(differs([](Controller& b) { b.derivative_on = DerivativeOn::kMeasurement; }));
  EXPECT_TRUE(differs([](Controller& b) { b.v_limit = 10.0; }));
  EXPECT_TRUE(differs([](Controller& b) { b.kp = std::nan(""); }));
}

}  // namespace
}  // namespace alphainv
