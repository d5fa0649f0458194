// Wall-clock time for the `seconds` that reports, timings and benchmarks carry.
#pragma once

#include <chrono>

namespace ieslam {

// Seconds elapsed since `start`, on the monotonic clock (system clock changes do not show).
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace ieslam
