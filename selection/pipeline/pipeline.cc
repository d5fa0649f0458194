#include "selection/pipeline/pipeline.h"

#include <chrono>

#include "core/error.h"
#include "core/freed_memory.h"
#include "core/stopwatch.h"

namespace ieslam {

const OptionTable<PipelineOptions>& PipelineOptions::Table() {
  static const OptionTable<PipelineOptions>* table = [] {
    using O = PipelineOptions;
    auto* t = new OptionTable<O>;
    t->Bool("refine", &O::refine, "bundle-adjust the selected frames (refined.tum)");
    t->Require([](const O& o) {
      return o.refine && o.selector.kind == SelectorKind::kDeadReckoning
                 ? "--refine needs a filter: not available with --selector deadreckoning"
                 : "";
    });
    return t;
  }();
  return *table;
}

bool PipelineOptions::Check(std::string* why) const {
  return Table().Check(*this, why) && selector.Check(why) && filter.Check(why) && ba.Check(why) &&
         depth_alignment.Check(why);
}

PipelineResult RunPipeline(FrameSource* source, const PinholeCamera& camera,
                           const PipelineOptions& options, const PipelineHooks& hooks,
                           const RangeCloudLoader& clouds, const PipelineResume* resume,
                           const Eigen::Isometry3d& T_colour_range) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError(why);
  PipelineResult result;
  result.filter = std::make_unique<InformationFilter>(options.filter, camera);
  if (resume != nullptr) result.filter->Restore(resume->filter);
  const auto selection_start = std::chrono::steady_clock::now();
  result.selection = KeyframeSelector(options.selector)
                         .Run(source, result.filter.get(), hooks.progress, hooks.stop,
                              hooks.on_decision, resume ? &resume->selection : nullptr);
  result.selection_wall_seconds = SecondsSince(selection_start);
  if (hooks.before_finish) hooks.before_finish(result.selection, *result.filter);
  source->Finish();
  // What the selection freed (processed frames, the descriptor database, SIFT's scratch in
  // the workers' arenas) goes back to the system before the map and the refinement allocate
  // theirs.
  ReturnFreedMemory();
  result.T_w_c = KeyframeSelector::FramePoses(result.selection, *result.filter);
  const bool dead_reckoning = !result.selection.chained_T_w_c.empty();
  if (dead_reckoning || result.filter->num_poses() == 0) return result;

  result.has_estimate = true;
  result.problem = MakeProblemFromFilter(*result.filter, result.selection.observations,
                                         result.selection.registered);
  const auto covariance_start = std::chrono::steady_clock::now();
  result.estimate = FilterEstimate(*result.filter);
  result.covariance_seconds = SecondsSince(covariance_start);
  if (!options.refine) return result;
  RangeClouds loaded;
  const bool align = clouds != nullptr && options.depth_alignment.rounds > 0;
  if (align) {
    const auto clouds_start = std::chrono::steady_clock::now();
    loaded = clouds(result.selection.selected, result.T_w_c);
    result.clouds_seconds = SecondsSince(clouds_start);
  }
  BundleAdjustmentOptions ba = options.ba;
  // A stop the selection obeyed ends the selection only; the refinement obeys a later one.
  if (!ba.stop && !result.selection.interrupted) ba.stop = hooks.stop;
  result.refinement = Refine(result.problem, camera, result.estimate, ba, options.depth_alignment,
                             align ? &loaded : nullptr, T_colour_range);
  return result;
}

}  // namespace ieslam
