// The virtual device's external push: parsing (errors name the option), the three profiles
// against their closed forms, and the device applying exactly that torque to its plant.
#include "alphainv/device/sim_push.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "alphainv/device/sim_transport.hpp"
#include "alphainv/error.hpp"

using namespace alphainv;
using namespace alphainv::device;

TEST(SimPush, ParsesTheThreeProfiles) {
  const SimPush ramp = parse_sim_push("ramp:0.02,start=0.5s,max=0.1");
  EXPECT_EQ(ramp.kind, SimPush::Kind::kRamp);
  EXPECT_EQ(ramp.level_v, 0.02);
  EXPECT_EQ(ramp.start_s, 0.5);
  EXPECT_EQ(ramp.max_v, 0.1);
  const SimPush hand = parse_sim_push("hand:-0.2,stiffness=3,damping=0,start=1");
  EXPECT_EQ(hand.kind, SimPush::Kind::kHand);
  EXPECT_EQ(hand.level_v, -0.2);
  EXPECT_EQ(hand.stiffness_v_per_rad, 3.0);
  EXPECT_EQ(hand.damping_v_s_per_rad, 0.0);
  EXPECT_EQ(hand.start_s, 1.0);
  const SimPush c = parse_sim_push("constant:-0.03");
  EXPECT_EQ(c.kind, SimPush::Kind::kConstant);
  EXPECT_EQ(c.level_v, -0.03);
  EXPECT_TRUE(std::isinf(c.max_v));
}

TEST(SimPush, BadTextIsRefusedNamingTheOption) {
  for (const char* bad : {"ramp", "ramp:", "ramp:0", "ramp:x", "push:0.1", "ramp:0.1,start=-1",
                          "ramp:0.1,max=0", "constant:0.1,max=1", "hand:0.2,stiffness=0",
                          "ramp:0.1,speed=2", "ramp:0.1,start"}) {
    SCOPED_TRACE(bad);
    try {
      (void)parse_sim_push(bad, "--sim-push");
      FAIL() << "no throw";
    } catch (const Error& e) {
      EXPECT_EQ(e.field(), "--sim-push");
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos);
    }
  }
}

TEST(SimPush, ProfilesFollowTheirClosedForms) {
  SimPush ramp = parse_sim_push("ramp:0.02,start=0.5,max=0.01");
  EXPECT_EQ(ramp.next(0.49, 0.0, 0.0), 0.0);
  EXPECT_NEAR(ramp.next(0.75, 0.0, 0.0), 0.005, 1e-15);
  EXPECT_EQ(ramp.next(2.0, 0.0, 0.0), 0.01);  // levelled off at max
  SimPush hand = parse_sim_push("hand:0.2,stiffness=2,damping=0.05,start=1");
  EXPECT_EQ(hand.next(0.5, 0.3, 0.0), 0.0);
  // Takes hold at θ = 0.1 at t = 1: θ_h = 0.1 + 0.2·(t − 1).
  EXPECT_NEAR(hand.next(1.0, 0.1, 0.0), 0.05 * 0.2, 1e-15);
  EXPECT_NEAR(hand.next(1.5, 0.15, 0.1), 2.0 * (0.2 - 0.15) + 0.05 * (0.2 - 0.1), 1e-15);
}

TEST(SimPush, TheDeviceAppliesThePushToItsPlant) {
  // The same plant stepped directly with the ramp as its disturbance: equal θ, bit for bit.
  VirtualOmniParams p;
  p.effects.coulomb_v = 0.01;
  VirtualDevice device(p, ReportScaling{}, SimFault{});
  device.set_push(parse_sim_push("ramp:0.05,start=0.1"));
  VirtualOmni plant(p);
  const SimPush ramp = parse_sim_push("ramp:0.05,start=0.1");
  OutputReport off;  // disabled: 0 V
  std::uint8_t buf[kOutputReportSize];
  for (int k = 0; k < 1500; ++k) {
    SimPush r = ramp;
    (void)plant.step(0.0, r.next(plant.time_s(), 0.0, 0.0));
    off.sequence = static_cast<std::uint16_t>(k);
    encode(off, buf);
    ASSERT_EQ(device.write(buf, sizeof buf), static_cast<int>(sizeof buf));
  }
  EXPECT_EQ(device.plant().theta(), plant.theta());
  EXPECT_GT(plant.theta(), 0.01);  // the push moved it (past the 0.01 V friction after 0.3 s)
}
