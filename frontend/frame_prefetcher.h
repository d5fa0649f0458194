// Pipelining: worker threads load, extract and lift the frames after the one the
// caller asked for while the caller selects and filters, through a bounded window of
// processed frames. Processing a frame does not depend on which thread does it (features are
// ordered by their own values, see features.h), so the threaded and the sequential mode hand
// out identical frames; only the timings differ.
//
// The window is bounded by a count of frames, not bytes: a processed frame holds its
// features and lifted points, a small fraction of its images' size, never the images, which
// are released as soon as the frame is processed.
#pragma once

#include <condition_variable>
#include <exception>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/dataset.h"
#include "core/option_table.h"
#include "frontend/frame_processor.h"

namespace ieslam {

struct PrefetchOptions {
  // Worker threads; 0 is the sequential mode: Take() loads and processes in the caller.
  int workers = 0;
  // Frames started ahead and not yet taken, at most (the memory bound).
  int capacity = 4;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<PrefetchOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct PrefetchedFrame {
  ProcessedFrame processed;
  double seconds_load = 0.0;  // reading and decoding the images
  // False when the range image holds no valid measurement at all; then the frame is not
  // processed (no features).
  bool has_valid_depth = true;
};

class FramePrefetcher {
 public:
  // `dataset` and `processor` must outlive the prefetcher and are only read (both are
  // const and safe to share between threads). The workers start at frame `first`.
  FramePrefetcher(const Dataset& dataset, const FrameProcessor& processor,
                  const PrefetchOptions& options, int first = 0);
  // Stops the workers; frames still in flight are finished and dropped.
  ~FramePrefetcher();
  FramePrefetcher(const FramePrefetcher&) = delete;
  FramePrefetcher& operator=(const FramePrefetcher&) = delete;

  // Frame `frame` loaded and processed, and the frames after it started on the workers.
  // Rethrows what loading or processing the frame threw (DataError for a bad image), in the
  // caller and for that frame only, as the sequential mode would. Frames before `frame`
  // that were prefetched and not taken are dropped; asking for one later processes it anew.
  PrefetchedFrame Take(int frame);

  // Time the caller spent blocked in Take() waiting for a worker, summed.
  double seconds_waited() const { return seconds_waited_; }

 private:
  struct Slot {
    bool done = false;
    PrefetchedFrame result;
    std::exception_ptr error;
  };

  PrefetchedFrame LoadAndProcess(int frame) const;
  void WorkerLoop();
  // Drops finished frames before `frame`. Needs mutex_ held.
  void DropBefore(int frame);

  const Dataset& dataset_;
  const FrameProcessor& processor_;
  const PrefetchOptions options_;

  std::mutex mutex_;
  std::condition_variable work_cv_;  // workers: room in the window, or stop
  std::condition_variable done_cv_;  // Take(): a frame finished
  std::map<int, Slot> slots_;        // started and not taken: in flight or done
  int next_ = 0;                     // the next frame a worker starts
  int taken_ = -1;                   // the latest frame taken
  bool stop_ = false;
  double seconds_waited_ = 0.0;
  std::vector<std::thread> threads_;
};

}  // namespace ieslam
