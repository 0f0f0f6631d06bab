#include "imukit/core/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

namespace imukit {
namespace {

TEST(ThreadCount, ZeroMeansTheMachineAndTheCountIsCappedByTheItems) {
  EXPECT_EQ(thread_count(4, 1000), 4u);
  EXPECT_EQ(thread_count(8, 3), 3u);
  EXPECT_EQ(thread_count(8, 0), 1u);
  EXPECT_EQ(thread_count(1, 0), 1u);
  EXPECT_GE(thread_count(0, 1000), 1u);
  EXPECT_LE(thread_count(0, 1000), std::max(1u, std::thread::hardware_concurrency()));
}

TEST(ParallelFor, RunsEveryItemExactlyOnceOnAnyThreadCount) {
  for (unsigned threads : {0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u}) {
    constexpr std::size_t n = 1000;
    std::vector<std::atomic<int>> runs(n);
    const unsigned workers = thread_count(threads, n);
    std::atomic<bool> worker_in_range{true};
    parallel_for(n, threads, [&](std::size_t item, unsigned worker) {
      runs[item].fetch_add(1);
      if (worker >= workers) worker_in_range = false;
    });
    for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(runs[i].load(), 1) << "item " << i;
    EXPECT_TRUE(worker_in_range) << threads << " threads";
  }
}

TEST(ParallelFor, NoItemsCallsNothing) {
  bool called = false;
  parallel_for(0, 4, [&](std::size_t, unsigned) { called = true; });
  EXPECT_FALSE(called);
}

TEST(ParallelFor, ThrowsTheExceptionOfAWorkerThread) {
  try {
    parallel_for(1000, 4, [](std::size_t item, unsigned) {
      if (item == 37) throw std::runtime_error("item 37");
    });
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "item 37");
  }
}

TEST(ParallelFor, ThrowsTheLowestFailingItemWhateverTheTiming) {
  for (unsigned threads : {1u, 2u, 4u, 8u}) {
    for (int repeat = 0; repeat < 20; ++repeat) {
      try {
        parallel_for(1000, threads, [](std::size_t item, unsigned) {
          if (item == 5) {  // give item 900 every chance to fail first
            std::this_thread::sleep_for(std::chrono::microseconds(200));
            throw std::runtime_error("item 5");
          }
          if (item == 900) throw std::runtime_error("item 900");
        });
        FAIL() << "no exception";
      } catch (const std::runtime_error& e) {
        ASSERT_EQ(std::string(e.what()), "item 5") << threads << " threads";
      }
    }
  }
}

TEST(ParallelFor, StartsNoItemAfterAFailure) {
  // One thread: exactly the items up to the failing one.
  std::atomic<std::size_t> started{0};
  EXPECT_THROW(parallel_for(1000, 1,
                            [&](std::size_t item, unsigned) {
                              started.fetch_add(1);
                              if (item == 10) throw std::runtime_error("stop");
                            }),
               std::runtime_error);
  EXPECT_EQ(started.load(), 11u);
  // Four threads: the others stop soon after (without the stop all 20000 items, 0.4 s, would run).
  started = 0;
  EXPECT_THROW(parallel_for(20000, 4,
                            [&](std::size_t item, unsigned) {
                              started.fetch_add(1);
                              if (item == 10) throw std::runtime_error("stop");
                              std::this_thread::sleep_for(std::chrono::microseconds(20));
                            }),
               std::runtime_error);
  EXPECT_LT(started.load(), 2000u);
}

}  // namespace
}  // namespace imukit
