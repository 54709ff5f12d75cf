#include "geardyn/parallel.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <vector>

namespace geardyn {
namespace {

TEST(ParallelFor, RunsEveryIndexOnceAndCountsTheUnits) {
  std::vector<std::atomic<int>> runs(100);
  std::vector<std::size_t> reported;
  const ParallelRun r = parallel_for(
      100, 4, 300,
      [&](std::size_t done, std::size_t total) {
        EXPECT_EQ(total, 300U);
        reported.push_back(done);  // one call at a time: no lock needed here
        return true;
      },
      [&](std::size_t i, WorkTicker& ticker) {
        ++runs[i];
        for (int unit = 0; unit < 3; ++unit) ticker.tick();
      });
  for (const auto& n : runs) EXPECT_EQ(n.load(), 1);
  ASSERT_EQ(reported.size(), 300U);
  // The callback hears 1, 2, ..., 300 in that order, whatever thread ticked.
  for (std::size_t k = 0; k < reported.size(); ++k) EXPECT_EQ(reported[k], k + 1);
  EXPECT_EQ(r.threads, 4U);
  EXPECT_FALSE(r.stopped);
  EXPECT_EQ(parallel_for(2, 8, 0, {}, [](std::size_t, WorkTicker&) {}).threads, 2U);
}

TEST(ParallelFor, AFalseProgressStopsTheWork) {
  std::atomic<int> started{0};
  const ParallelRun r = parallel_for(
      1000, 2, 1000, [](std::size_t done, std::size_t) { return done < 5; },
      [&](std::size_t, WorkTicker& ticker) {
        ++started;
        ticker.tick();
      });
  EXPECT_TRUE(r.stopped);
  EXPECT_LT(started.load(), 1000);
}

TEST(ParallelFor, TheFirstExceptionIsRethrownAfterTheThreadsEnd) {
  const auto job = [](std::atomic<int>& finished) {
    return [&finished](std::size_t i, WorkTicker&) {
      if (i == 7) throw std::runtime_error("job 7");
      ++finished;
    };
  };
  std::atomic<int> many{0};
  EXPECT_THROW(parallel_for(50, 3, 50, {}, job(many)), std::runtime_error);
  // On one thread the order is known: the jobs after the failing one do not start.
  std::atomic<int> one{0};
  EXPECT_THROW(parallel_for(50, 1, 50, {}, job(one)), std::runtime_error);
  EXPECT_EQ(one.load(), 7);
}

}  // namespace
}  // namespace geardyn
