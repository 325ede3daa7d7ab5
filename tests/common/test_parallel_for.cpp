// Tests of src/common/parallel_for.hpp: every index runs once, each job's result lands in its
// own slot (the same as a serial loop, bit for bit), 0 and 1 jobs, the thread-count rule, and an
// exception thrown by a job reaches the caller.

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "common/parallel_for.hpp"

namespace alphainv::common {
namespace {

TEST(ThreadCount, RequestedOrHardwareNeverMoreThanTheJobs) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  EXPECT_EQ(thread_count(4, 100), 4u);
  EXPECT_EQ(thread_count(4, 3), 3u);
  EXPECT_EQ(thread_count(4, 0), 1u);
  EXPECT_EQ(thread_count(1, 100), 1u);
  EXPECT_EQ(thread_count(0, 1000), std::min(hw, 1000u));
  EXPECT_EQ(thread_count(0, 1), 1u);
}

TEST(ParallelFor, EveryIndexOnce) {
  for (unsigned threads : {0u, 1u, 2u, 3u, 8u}) {
    const std::size_t n = 1000;
    std::vector<std::atomic<int>> count(n);
    parallel_for(n, threads, [&](std::size_t i) { ++count[i]; });
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(count[i].load(), 1) << i << ", threads " << threads;
    }
  }
}

TEST(ParallelFor, ResultsPerSlotEqualASerialLoop) {
  const std::size_t n = 257;
  auto job = [](std::size_t i) {
    double s = 0.0;
    for (std::size_t k = 1; k <= 200 + i; ++k) {
      s += std::sin(static_cast<double>(k * (i + 1))) / static_cast<double>(k);
    }
    return s;
  };
  std::vector<double> serial(n), parallel(n);
  for (std::size_t i = 0; i < n; ++i) serial[i] = job(i);
  parallel_for(n, 4, [&](std::size_t i) { parallel[i] = job(i); });
  EXPECT_EQ(parallel, serial);  // bit-identical
}

TEST(ParallelFor, ZeroJobsCallsNothing) {
  std::atomic<int> calls{0};
  parallel_for(0, 4, [&](std::size_t) { ++calls; });
  parallel_for(0, 0, [&](std::size_t) { ++calls; });
  EXPECT_EQ(calls.load(), 0);
}

TEST(ParallelFor, OneJobRunsOnTheCallingThread) {
  std::thread::id ran_on;
  std::size_t index = 99;
  parallel_for(1, 8, [&](std::size_t i) {
    ran_on = std::this_thread::get_id();
    index = i;
  });
  EXPECT_EQ(index, 0u);
  EXPECT_EQ(ran_on, std::this_thread::get_id());
}

TEST(ParallelFor, OneThreadRunsInOrderOnTheCaller) {
  std::vector<std::size_t> order;
  std::set<std::thread::id> ids;
  parallel_for(5, 1, [&](std::size_t i) {
    order.push_back(i);
    ids.insert(std::this_thread::get_id());
  });
  EXPECT_EQ(order, (std::vector<std::size_t>{0, 1, 2, 3, 4}));
  EXPECT_EQ(ids, std::set<std::thread::id>{std::this_thread::get_id()});
}

TEST(ParallelFor, AnExceptionInAJobReachesTheCaller) {
  for (unsigned threads : {1u, 4u}) {
    std::atomic<int> ran{0};
    try {
      parallel_for(100, threads, [&](std::size_t i) {
        ++ran;
        if (i == 7) throw std::runtime_error("job 7 failed");
      });
      ADD_FAILURE() << "no exception, threads " << threads;
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "job 7 failed");
    }
    // Jobs 0..7 were handed out before 7 failed, so they ran; on one thread none after it (on
    // more, the others may take a few before they see the failure).
    EXPECT_GE(ran.load(), 8);
    if (threads == 1) {
      EXPECT_EQ(ran.load(), 8);
    }
  }
}

TEST(ParallelFor, OnlyTheFirstOfSeveralExceptions) {
  try {
    parallel_for(10, 1,
                 [&](std::size_t i) { throw std::runtime_error("job " + std::to_string(i)); });
    ADD_FAILURE() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "job 0");
  }
}

}  // namespace
}  // namespace alphainv::common
