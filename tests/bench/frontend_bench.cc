// Front-end micro-benchmarks on real 7-Scenes frames: SIFT extraction, lifting, exact pair
// matching, FLANN database ranking against growing databases, RANSAC registration.
// Run through scripts/bench.sh (single-threaded OpenCV).
#include <benchmark/benchmark.h>

#include <memory>

#include <opencv2/core.hpp>

#include "core/dataset.h"
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
                                              f.processed[0].features.descriptors, f.options.matching));
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

}  // namespace
}  // namespace ieslam
