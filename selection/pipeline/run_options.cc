#include "selection/pipeline/run_options.h"

#include <algorithm>
#include <set>
#include <thread>

#include "core/error.h"

namespace ieslam {
namespace {

// Threads that load and process frames ahead of the selector: none in the deterministic
// single-thread mode, else one per core (the selector's own thread mostly waits for
// processed frames, so it is not counted); more than a few only queue behind the selector.
int PrefetchWorkers(int threads) {
  if (threads == 1) return 0;
  return std::clamp(WorkerThreads(threads), 1, 3);
}

}  // namespace

int WorkerThreads(int threads) {
  return threads > 0 ? threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

const OptionTable<RunOptions>& RunOptions::Table() {
  static const OptionTable<RunOptions>* table = [] {
    using O = RunOptions;
    auto* t = new OptionTable<O>;
    t->Int("threads", &O::threads, "0: every core; 1: the deterministic single-thread mode")
        .Range(0, 256);
    t->Uint("seed", &O::seed, "seed of RANSAC and of FLANN's trees");
    t->Bool("write_map", &O::build_map, "build and write map.ply");
    t->Bool("save_map", &O::save_map,
            "write map/map.bin: base frames, features, poses and the filter, for later sessions");
    return t;
  }();
  return *table;
}

const OptionRegistry<RunOptions>& RunOptions::Registry() {
  static const OptionRegistry<RunOptions>* registry = [] {
    auto* r = new OptionRegistry<RunOptions>;
    r->Section<DatasetOptions>("dataset", DatasetOptions::Table(),
                               [](RunOptions* o) { return &o->dataset_options; });
    r->Section<FeatureOptions>("features", FeatureOptions::Table(),
                               [](RunOptions* o) { return &o->source.frontend.features; });
    r->Section<MatchOptions>("matching", MatchOptions::Table(),
                             [](RunOptions* o) { return &o->source.frontend.matching; });
    r->Section<LiftingOptions>("lifting", LiftingOptions::Table(),
                               [](RunOptions* o) { return &o->source.frontend.lifting; });
    r->Section<RegistrationOptions>("registration", RegistrationOptions::Table(),
                                    [](RunOptions* o) { return &o->source.frontend.registration; });
    r->Section<DatabaseOptions>("database", DatabaseOptions::Table(),
                                [](RunOptions* o) { return &o->source.database; });
    r->Section<RgbdSourceOptions>("source", RgbdSourceOptions::Table(),
                                  [](RunOptions* o) { return &o->source; });
    r->Section<PrefetchOptions>("prefetch", PrefetchOptions::Table(),
                                [](RunOptions* o) { return &o->source.prefetch; });
    r->Section<SelectorOptions>("selector", SelectorOptions::Table(),
                                [](RunOptions* o) { return &o->pipeline.selector; });
    r->Section<InformationFilterOptions>("filter", InformationFilterOptions::Table(),
                                         [](RunOptions* o) { return &o->pipeline.filter; });
    r->Section<DenseMapOptions>("map", DenseMapOptions::Table(),
                                [](RunOptions* o) { return &o->map; });
    r->Section<BundleAdjustmentOptions>("ba", BundleAdjustmentOptions::Table(),
                                        [](RunOptions* o) { return &o->pipeline.ba; });
    r->Section<DepthAlignmentOptions>("depth_alignment", DepthAlignmentOptions::Table(),
                                      [](RunOptions* o) { return &o->pipeline.depth_alignment; });
    r->Section<RangeCloudOptions>("depth_alignment", RangeCloudOptions::Table(),
                                  [](RunOptions* o) { return &o->range_cloud; });
    r->Section<LocalizeOptions>("localize", LocalizeOptions::Table(),
                                [](RunOptions* o) { return &o->localize; });
    r->Section<RunOptions>("", RunOptions::Table(), [](RunOptions* o) { return o; });
    r->Section<PipelineOptions>("", PipelineOptions::Table(),
                                [](RunOptions* o) { return &o->pipeline; });
    return r;
  }();
  return *registry;
}

bool RunOptions::Check(std::string* why) const {
  if (dataset.empty()) {
    if (why != nullptr) *why = "--dataset is required";
    return false;
  }
  return Registry().Check(*this, why);
}

RunOptions RunOptions::Resolved() const {
  RunOptions used = *this;
  used.source.frontend.registration.seed = seed;
  used.source.database.seed = seed;
  used.source.prefetch.workers = PrefetchWorkers(threads);
  // A frame's registrations to its base candidates are independent: any number of threads
  // gives the same ones.
  used.source.registration_threads = WorkerThreads(threads);
  if (threads > 0) used.pipeline.ba.num_threads = threads;
  // Pairs align independently: any number of threads gives the same constraints.
  used.pipeline.depth_alignment.num_threads = WorkerThreads(threads);
  return used;
}

Json RunOptions::ToJson() const { return Registry().ToJson(Resolved()); }

void ApplyConfigFile(const std::string& path, RunOptions* options) {
  RunOptions::Registry().ApplyYaml(path, options);
  std::string why;
  if (!RunOptions::Registry().Check(*options, &why)) throw ConfigError(path + ": " + why);
}

namespace {

// Applies the options of `sections` in `config` (`source` names it in errors) to *options.
void ApplySections(const std::string& config, const std::string& source,
                   const std::set<std::string>& sections, RunOptions* options) {
  std::vector<YamlOption> chosen;
  for (YamlOption& o : ParseYamlOptions(config, source)) {
    if (sections.count(o.section) > 0) chosen.push_back(std::move(o));
  }
  RunOptions::Registry().ApplyOptions(chosen, source, options);
}

}  // namespace

void ApplyMapFrontEndOptions(const std::string& config, const std::string& source,
                             RunOptions* options) {
  // The source section too: its checks tie it to the registration's (a map made with a raised
  // min_inliers also raised min_inliers_secondary).
  ApplySections(config, source,
                {"features", "lifting", "matching", "registration", "database", "source"}, options);
}

DatasetOptions MapDatasetOptions(const std::string& config, const std::string& source) {
  RunOptions options;
  ApplySections(config, source, {"dataset"}, &options);
  const DatasetOptions whole;
  options.dataset_options.first = whole.first;
  options.dataset_options.last = whole.last;
  options.dataset_options.stride = whole.stride;
  return options.dataset_options;
}

std::string ConfigYaml(const RunOptions& options) {
  return RunOptions::Registry().ToYaml(
      options,
      "# The options of every stage for `ieslam run --config FILE`, each with its default\n"
      "# (`ieslam options` writes this file). Copy, keep the keys you change.\n");
}

}  // namespace ieslam
