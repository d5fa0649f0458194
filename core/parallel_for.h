// A loop over independent items on a few threads, for work whose result does not depend on
// which thread runs which item.
#pragma once

#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <system_error>
#include <thread>
#include <vector>

namespace ieslam {

// Runs work(k) for k in [0, count) on up to `threads` threads (the caller's among them),
// each taking the next item as it finishes one. The first exception work throws stops the
// items not yet taken and is rethrown here once every thread is done; a thread the system
// refuses to start leaves its share to the others.
template <typename Work>
void ParallelFor(size_t count, int threads, const Work& work) {
  std::atomic<size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto run = [&]() {
    try {
      for (size_t k = next++; k < count; k = next++) work(k);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = count;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads && static_cast<size_t>(t) < count; ++t) {
    try {
      pool.emplace_back(run);
    } catch (const std::system_error&) {
      break;
    }
  }
  run();
  for (std::thread& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace ieslam
