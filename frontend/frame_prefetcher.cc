#include "frontend/frame_prefetcher.h"

#include <algorithm>
#include <chrono>

#include <glog/logging.h>

#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/stopwatch.h"

namespace ieslam {

const OptionTable<PrefetchOptions>& PrefetchOptions::Table() {
  static const OptionTable<PrefetchOptions>* table = [] {
    using O = PrefetchOptions;
    auto* t = new OptionTable<O>;
    t->Int("workers", &O::workers, "prefetch threads: from the run's threads")
        .Range(0, 64)
        .Derived();
    t->Int("capacity", &O::capacity, "frames processed ahead at most (the memory bound)").Min(1);
    return t;
  }();
  return *table;
}

FramePrefetcher::FramePrefetcher(const Dataset& dataset, const FrameProcessor& processor,
                                 const PrefetchOptions& options, int first)
    : dataset_(dataset), processor_(processor), options_(options), next_(first) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  for (int w = 0; w < options.workers; ++w) threads_.emplace_back([this] { WorkerLoop(); });
}

FramePrefetcher::~FramePrefetcher() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  work_cv_.notify_all();
  for (std::thread& thread : threads_) thread.join();
}

PrefetchedFrame FramePrefetcher::LoadAndProcess(int frame) const {
  PrefetchedFrame out;
  const auto start = std::chrono::steady_clock::now();
  const Frame loaded = dataset_.Load(frame);  // the images are released when this returns
  out.seconds_load = SecondsSince(start);
  out.has_valid_depth = cv::countNonZero(loaded.depth) > 0;
  if (out.has_valid_depth) out.processed = processor_.Process(loaded);
  return out;
}

void FramePrefetcher::WorkerLoop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    work_cv_.wait(lock, [this] {
      return stop_ ||
             (next_ < dataset_.size() && static_cast<int>(slots_.size()) < options_.capacity);
    });
    if (stop_) return;
    const int frame = next_++;
    slots_.emplace(frame, Slot());  // in flight: Take() of this frame waits for it
    lock.unlock();
    Slot finished;
    try {
      finished.result = LoadAndProcess(frame);
    } catch (...) {
      // Handed to the caller that takes this frame, where the sequential mode throws too.
      finished.error = std::current_exception();
    }
    finished.done = true;
    lock.lock();
    slots_.at(frame) = std::move(finished);
    done_cv_.notify_all();
  }
}

void FramePrefetcher::DropBefore(int frame) {
  for (auto it = slots_.begin(); it != slots_.end() && it->first < frame;) {
    it = it->second.done ? slots_.erase(it) : std::next(it);
  }
}

PrefetchedFrame FramePrefetcher::Take(int frame) {
  CHECK_GE(frame, 0);
  CHECK_LT(frame, dataset_.size());
  if (threads_.empty()) return LoadAndProcess(frame);

  std::unique_lock<std::mutex> lock(mutex_);
  taken_ = std::max(taken_, frame);
  auto it = slots_.find(frame);
  if (it == slots_.end()) {
    // Not started (a jump ahead, or a frame taken or dropped before): process it here;
    // the workers go on after it.
    next_ = std::max(next_, frame + 1);
    DropBefore(taken_);
    lock.unlock();
    work_cv_.notify_all();
    return LoadAndProcess(frame);
  }
  const auto start = std::chrono::steady_clock::now();
  // `it` stays valid: only Take() erases slots, and a worker only assigns to its own.
  done_cv_.wait(lock, [&it] { return it->second.done; });
  seconds_waited_ += SecondsSince(start);
  Slot slot = std::move(it->second);
  slots_.erase(it);
  DropBefore(taken_);
  lock.unlock();
  work_cv_.notify_all();
  if (slot.error) std::rethrow_exception(slot.error);
  return std::move(slot.result);
}

}  // namespace ieslam
