#include "selection/pipeline/options_json.h"

#include "selection/pipeline/dataset_run.h"

namespace ieslam {

Json SelectorOptionsToJson(const SelectorOptions& selector) {
  return Json::Object()
      .Set("kind", SelectorKindName(selector.kind))
      .Set("buffer", selector.buffer_size)
      .Set("interval", selector.interval)
      .Set("min_common_features", selector.min_common_features)
      .Set("map_gain_threshold", selector.map_gain_threshold)
      .Set("max_recovery_frames", selector.max_recovery_frames)
      .Set("min_view_change_deg", selector.min_view_change_deg);
}

Json FilterOptionsToJson(const InformationFilterOptions& filter) {
  return Json::Object()
      .Set("anchor_information", filter.anchor_information)
      .Set("iterative_recovery", filter.iterative_recovery)
      .Set("cg_tolerance", filter.cg_tolerance)
      .Set("max_dense_pose_dim", filter.max_dense_pose_dim);
}

Json BaOptionsToJson(const BundleAdjustmentOptions& options) {
  return Json::Object()
      .Set("robust_loss", BaRobustLossName(options.robust_loss))
      .Set("huber_scale", options.huber_scale)
      .Set("rejection_chi2", options.rejection_chi2)
      .Set("max_rejection_rounds", options.max_rejection_rounds)
      .Set("max_iterations", options.max_iterations);
}

Json DepthAlignmentOptionsToJson(const DepthAlignmentOptions& options,
                                 const RangeCloudOptions& cloud) {
  return Json::Object()
      .Set("rounds", options.rounds)
      .Set("grid_step", cloud.step)
      .Set("sample_step", options.sample_step)
      .Set("initial_gate_m", options.initial_gate_m)
      .Set("final_gate_m", options.final_gate_m)
      .Set("max_normal_angle_deg", options.max_normal_angle_deg)
      .Set("huber_sigmas", options.huber_sigmas)
      .Set("min_overlap", options.min_overlap)
      .Set("max_robust_sigma", options.max_robust_sigma)
      .Set("max_partners", options.max_partners);
}

Json DatasetOptionsToJson(const DatasetOptions& options) {
  return Json::Object()
      .Set("format", options.format)
      .Set("calib", options.calib_file)
      .Set("first", options.first)
      .Set("last", options.last)
      .Set("stride", options.stride)
      .Set("max_association_diff_s", options.max_association_diff_s);
}

Json RunOptionsToJson(const RunOptions& options) {
  const RgbdSourceOptions& source = options.source;
  const FeatureOptions& f = source.frontend.features;
  const LiftingOptions& l = source.frontend.lifting;
  const RegistrationOptions& r = source.frontend.registration;
  Json json = Json::Object();
  json.Set("dataset", DatasetOptionsToJson(options.dataset_options));
  json["features"]
      .Set("max_features", f.max_features)
      .Set("contrast_threshold", f.contrast_threshold)
      .Set("edge_threshold", f.edge_threshold)
      .Set("octave_layers", f.octave_layers)
      .Set("image_scale", f.image_scale);
  json["matching"]
      .Set("ratio", source.frontend.matching.ratio)
      .Set("mutual", source.frontend.matching.mutual);
  json["lifting"]
      .Set("window_radius", l.window_radius)
      .Set("sigma_multiplier", l.sigma_multiplier)
      .Set("footprint_multiplier", l.footprint_multiplier)
      .Set("edge_sigma_multiplier", l.edge_sigma_multiplier)
      .Set("min_valid_in_window", l.min_valid_in_window);
  json["registration"]
      .Set("inlier_threshold_m", r.inlier_threshold_m)
      .Set("max_iterations", r.max_iterations)
      .Set("probability", r.probability)
      .Set("min_inliers", r.min_inliers)
      .Set("min_spread_m", r.min_spread_m)
      .Set("inlier_chi2", r.inlier_chi2)
      .Set("use_point_covariances", r.use_point_covariances)
      .Set("seed", static_cast<int64_t>(r.seed));
  json["database"]
      .Set("trees", source.database.trees)
      .Set("checks", source.database.checks)
      .Set("neighbours", source.database.neighbours)
      .Set("ratio", source.database.ratio)
      .Set("seed", static_cast<int64_t>(source.database.seed));
  json["source"]
      .Set("max_base_candidates", source.max_base_candidates)
      .Set("max_new_features_per_frame", source.max_new_features_per_frame)
      .Set("min_inliers_secondary", source.min_inliers_secondary);
  json.Set("selector", SelectorOptionsToJson(options.pipeline.selector));
  json.Set("filter", FilterOptionsToJson(options.pipeline.filter));
  json["map"]
      .Set("voxel_size_m", options.map.voxel_size_m)
      .Set("pixel_step", options.map.pixel_step);
  json.Set("ba", BaOptionsToJson(options.pipeline.ba));
  json.Set("depth_alignment",
           DepthAlignmentOptionsToJson(options.pipeline.depth_alignment, options.range_cloud));
  json.Set("threads", options.threads);
  return json;
}

}  // namespace ieslam
