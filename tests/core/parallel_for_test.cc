#include "core/parallel_for.h"

#include <atomic>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

TEST(ParallelForTest, RunsEveryItemOnceOnAnyNumberOfThreads) {
  for (int threads : {1, 2, 5}) {
    for (size_t count : {size_t{0}, size_t{1}, size_t{3}, size_t{100}}) {
      std::vector<std::atomic<int>> runs(count);
      ParallelFor(count, threads, [&](size_t k) { ++runs[k]; });
      for (size_t k = 0; k < count; ++k) {
        EXPECT_EQ(runs[k].load(), 1)
            << "item " << k << " of " << count << ", " << threads << " threads";
      }
    }
  }
}

// An exception from one item reaches the caller (a thread's would otherwise end the
// process), after every thread is done.
TEST(ParallelForTest, RethrowsTheExceptionOfAnItemToTheCaller) {
  for (int threads : {1, 3}) {
    std::atomic<int> done{0};
    EXPECT_THROW(ParallelFor(50, threads,
                             [&](size_t k) {
                               if (k == 7) throw std::runtime_error("item 7");
                               ++done;
                             }),
                 std::runtime_error);
    // One thread takes the items in order and stops at the one that threw.
    if (threads == 1) EXPECT_EQ(done.load(), 7);
  }
}

}  // namespace
}  // namespace ieslam
