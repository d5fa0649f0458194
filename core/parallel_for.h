// A loop over independent items on a few threads, for work whose result does not depend on
// which thread runs which item.
#pragma once

#include <atomic>
#include <cstddef>
#include <thread>
#include <vector>

namespace ieslam {

// Runs work(k) for k in [0, count) on `threads` threads (the caller's among them), each
// taking the next item as it finishes one. work must not throw.
template <typename Work>
void ParallelFor(size_t count, int threads, const Work& work) {
  std::atomic<size_t> next{0};
  auto run = [&]() {
    for (size_t k = next++; k < count; k = next++) work(k);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads && static_cast<size_t>(t) < count; ++t) pool.emplace_back(run);
  run();
  for (std::thread& thread : pool) thread.join();
}

}  // namespace ieslam
