// SpscRing: FIFO order, full/empty, capacity rounding, and a two-thread run that checks every
// value arrives once and in order.
#include <gtest/gtest.h>

#include <thread>

#include "alphainv/error.hpp"
#include "alphainv/rt/spsc_ring.hpp"

using alphainv::rt::SpscRing;

TEST(SpscRing, FifoFullAndEmpty) {
  SpscRing<int> ring(3);
  EXPECT_EQ(ring.capacity(), 4u);
  int out = 0;
  EXPECT_FALSE(ring.pop(out));
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(ring.push(i));
  EXPECT_FALSE(ring.push(99));
  EXPECT_EQ(ring.size(), 4u);
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(ring.pop(out));
    EXPECT_EQ(out, i);
  }
  EXPECT_FALSE(ring.pop(out));
  EXPECT_THROW(SpscRing<int>(0), alphainv::Error);
}

TEST(SpscRing, TwoThreadsKeepOrder) {
  SpscRing<long> ring(64);
  constexpr long kN = 200000;
  std::thread producer([&] {
    for (long i = 0; i < kN; ++i) {
      while (!ring.push(i)) std::this_thread::yield();
    }
  });
  long expected = 0, value = 0;
  while (expected < kN) {
    if (ring.pop(value)) {
      ASSERT_EQ(value, expected);
      ++expected;
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
  EXPECT_EQ(ring.size(), 0u);
}
