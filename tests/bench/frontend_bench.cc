// Front-end micro-benchmarks on real 7-Scenes frames: image loading, SIFT extraction,
// lifting, exact pair matching, FLANN database ranking against growing databases, RANSAC
// registration (one pair, and one frame against 8 base frames on 1 and 2 threads), and the
// whole per-frame front end (features + matching against the previous frame + lifting +
// RANSAC; target <= 40 ms). Run through scripts/bench.sh; OpenCV runs single-threaded.
#include <benchmark/benchmark.h>

#include <memory>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/dataset.h"
#include "core/parallel_for.h"
#include "frontend/frame_processor.h"

namespace ieslam {
namespace {

const std::string kSevenScenes = std::string(IESLAM_SHARED_DATA_DIR) + "/7scenes-dev";

struct Fixture {
  std::unique_ptr<Dataset> dataset;
  std::vector<Frame> frames;
  std::vector<ProcessedFrame> processed;
  FrontendOptions options;

  Fixture() {
    cv::setNumThreads(1);
    dataset = OpenDataset(kSevenScenes, DatasetOptions());
    const FrameProcessor processor(dataset->rig(), options);
    for (int i = 0; i < 200; i += 5) {
      frames.push_back(dataset->Load(i));
      processed.push_back(processor.Process(frames.back()));
    }
  }
};

Fixture& Shared() {
  static Fixture fixture;
  return fixture;
}

void BM_ExtractFeatures(benchmark::State& state) {
  Fixture& f = Shared();
  FeatureOptions options;
  options.image_scale = state.range(0) / 100.0;
  size_t i = 0;
  int keypoints = 0;
  for (auto _ : state) {
    const FrameFeatures features = ExtractFeatures(f.frames[i++ % f.frames.size()].colour, options);
    keypoints = features.size();
    benchmark::DoNotOptimize(keypoints);
  }
  state.counters["keypoints"] = keypoints;
}
BENCHMARK(BM_ExtractFeatures)->Arg(50)->Arg(100)->Unit(benchmark::kMillisecond);

void BM_LiftFeatures(benchmark::State& state) {
  Fixture& f = Shared();
  const FeatureLifter lifter(f.dataset->rig(), f.options.lifting);
  const FrameFeatures features = ExtractFeatures(f.frames[0].colour, f.options.features);
  for (auto _ : state) benchmark::DoNotOptimize(lifter.Lift(features.pixels, f.frames[0].depth));
  state.counters["keypoints"] = features.size();
}
BENCHMARK(BM_LiftFeatures)->Unit(benchmark::kMillisecond);

void BM_MatchPair(benchmark::State& state) {
  Fixture& f = Shared();
  for (auto _ : state) {
    benchmark::DoNotOptimize(MatchDescriptors(f.processed[1].features.descriptors,
                                              f.processed[0].features.descriptors,
                                              f.options.matching));
  }
}
BENCHMARK(BM_MatchPair)->Unit(benchmark::kMillisecond);

void BM_RankDatabase(benchmark::State& state) {
  Fixture& f = Shared();
  BaseFrameDatabase database{DatabaseOptions()};
  const int frames = static_cast<int>(state.range(0));
  for (int k = 0; k < frames; ++k) {
    // Beyond the distinct frames, repeat them: the index size is what matters here.
    database.Add(k, f.processed[k % (f.processed.size() - 1) + 1].features.descriptors);
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(database.RankFrames(f.processed[0].features.descriptors, 4));
  }
  state.counters["base_frames"] = frames;
}
BENCHMARK(BM_RankDatabase)->Arg(10)->Arg(50)->Arg(150)->Unit(benchmark::kMillisecond);

// Adding base frames one by one, index rebuilds included: the database's cost per base frame.
void BM_DatabaseAdd(benchmark::State& state) {
  Fixture& f = Shared();
  const int frames = static_cast<int>(state.range(0));
  for (auto _ : state) {
    BaseFrameDatabase database{DatabaseOptions()};
    for (int k = 0; k < frames; ++k)
      database.Add(k, f.processed[k % f.processed.size()].features.descriptors);
    benchmark::DoNotOptimize(database.num_frames());
  }
  state.counters["ms_per_base_frame"] = benchmark::Counter(
      frames, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_DatabaseAdd)->Arg(150)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_RegisterPair(benchmark::State& state) {
  Fixture& f = Shared();
  int inliers = 0;
  for (auto _ : state) {
    const FrameRegistration r =
        RegisterFrames(f.processed[0], f.processed[1], f.options.matching, f.options.registration);
    inliers = static_cast<int>(r.result.inliers.size());
  }
  state.counters["inliers"] = inliers;
}
BENCHMARK(BM_RegisterPair)->Unit(benchmark::kMillisecond);

// One frame registered against the 8 base candidates a frame is registered to, on N
// threads, as RgbdFrameSource does for each prepared frame (registration_threads).
void BM_RegisterAgainstBases(benchmark::State& state) {
  Fixture& f = Shared();
  const int threads = static_cast<int>(state.range(0));
  constexpr size_t kBases = 8;
  std::vector<FrameRegistration> out(kBases);
  for (auto _ : state) {
    ParallelFor(kBases, threads, [&](size_t i) {
      out[i] = RegisterFrames(f.processed[1 + i], f.processed[0], f.options.matching,
                              f.options.registration);
    });
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["threads"] = threads;
}
BENCHMARK(BM_RegisterAgainstBases)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Reading a frame from disk (the files are in the page cache after the first pass): colour
// JPEG decoding, 16-bit PNG decoding, and Dataset::Load with the depth conversion to metres.
void BM_DecodeColour(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cv::imread(f.dataset->info(i++ % 200).colour_path, cv::IMREAD_COLOR));
  }
}
BENCHMARK(BM_DecodeColour)->Unit(benchmark::kMillisecond);

void BM_DecodeDepth(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        cv::imread(f.dataset->info(i++ % 200).depth_path, cv::IMREAD_UNCHANGED));
  }
}
BENCHMARK(BM_DecodeDepth)->Unit(benchmark::kMillisecond);

void BM_LoadFrame(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(f.dataset->Load(i++ % 200));
}
BENCHMARK(BM_LoadFrame)->Unit(benchmark::kMillisecond);

// The front end's time per frame: the new frame's features and lifting, then matching
// and RANSAC against the previous frame (5 frames earlier, as `ieslam register --step 5`).
// Images are in memory; BM_LoadFrame is the loading on top.
void BM_FrontendPerFrame(benchmark::State& state) {
  Fixture& f = Shared();
  const FrameProcessor processor(f.dataset->rig(), f.options);
  size_t i = 1;
  int failures = 0, frames = 0;
  for (auto _ : state) {
    const size_t k = i++ % f.frames.size();
    const ProcessedFrame current = processor.Process(f.frames[k]);
    const ProcessedFrame& previous = f.processed[k == 0 ? f.frames.size() - 1 : k - 1];
    const FrameRegistration r =
        RegisterFrames(previous, current, f.options.matching, f.options.registration);
    failures += r.result.success ? 0 : 1;
    ++frames;
  }
  state.counters["failed_share"] = frames > 0 ? static_cast<double>(failures) / frames : 0.0;
}
BENCHMARK(BM_FrontendPerFrame)->Unit(benchmark::kMillisecond);

// The same with the frame read from disk first: what one frame costs a single thread end
// to end before selection.
void BM_LoadAndFrontendPerFrame(benchmark::State& state) {
  Fixture& f = Shared();
  const FrameProcessor processor(f.dataset->rig(), f.options);
  size_t i = 1;
  for (auto _ : state) {
    const size_t k = i++ % f.frames.size();
    const ProcessedFrame current = processor.Process(f.dataset->Load(static_cast<int>(5 * k)));
    const ProcessedFrame& previous = f.processed[k == 0 ? f.frames.size() - 1 : k - 1];
    benchmark::DoNotOptimize(
        RegisterFrames(previous, current, f.options.matching, f.options.registration));
  }
}
BENCHMARK(BM_LoadAndFrontendPerFrame)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace ieslam
