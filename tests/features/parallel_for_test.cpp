// The parallel loop behind SURF and quantisation: every task runs once, whatever the thread
// counts and however many callers share the helper threads, and a task's exception reaches its
// caller, on whichever thread it ran, without leaving the helpers stuck.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include "features/parallel_for.h"

namespace placedb {
namespace {

TEST(ParallelFor, RunsEveryTaskOnceForAnyCountAndThreads) {
  for (int threads : {1, 2, 3, 8}) {
    for (int count : {0, 1, 2, 7, 100, 1000}) {
      std::vector<std::atomic<int>> runs(static_cast<std::size_t>(count));
      parallelFor(count, threads, [&](int i) { runs[static_cast<std::size_t>(i)].fetch_add(1); });
      for (int i = 0; i < count; ++i)
        ASSERT_EQ(runs[static_cast<std::size_t>(i)].load(), 1)
            << threads << " threads, " << count << " tasks, task " << i;
    }
  }
}

TEST(ParallelFor, CallersOnSeveralThreadsShareTheHelpers) {
  constexpr int kCallers = 4, kRounds = 200, kTasks = 64;
  std::vector<std::thread> callers;
  std::atomic<int> wrong{0};
  for (int c = 0; c < kCallers; ++c) {
    callers.emplace_back([&, c] {
      for (int round = 0; round < kRounds; ++round) {
        std::vector<int> out(kTasks, 0);
        parallelFor(kTasks, 1 + (c + round) % 4,
                    [&](int i) { out[static_cast<std::size_t>(i)] = i + c; });
        for (int i = 0; i < kTasks; ++i)
          if (out[static_cast<std::size_t>(i)] != i + c) wrong.fetch_add(1);
      }
    });
  }
  for (auto& t : callers) t.join();
  EXPECT_EQ(wrong.load(), 0);
}

TEST(ParallelFor, AnExceptionReachesTheCallerAndTheLoopGoesOnWorking) {
  for (int attempt = 0; attempt < 50; ++attempt) {
    std::atomic<int> runs{0};
    EXPECT_THROW(parallelFor(50, 2,
                             [&](int i) {
                               runs.fetch_add(1);
                               if (i == 7) throw std::runtime_error("task failed");
                             }),
                 std::runtime_error);
    EXPECT_LE(runs.load(), 50);
  }
  std::atomic<int> runs{0};
  parallelFor(100, 2, [&](int) { runs.fetch_add(1); });
  EXPECT_EQ(runs.load(), 100);
}

}  // namespace
}  // namespace placedb
