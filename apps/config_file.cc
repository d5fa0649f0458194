#include "apps/config_file.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include <opencv2/core.hpp>

#include "core/error.h"
#include "core/yaml_text.h"

namespace ieslam {
namespace {

// Reads one section's keys into typed targets.
class Section {
 public:
  Section(const cv::FileNode& node, std::string where) : node_(node), where_(std::move(where)) {}

  void Double(const std::string& key, double* target) {
    known_.push_back(key);
    const cv::FileNode n = node_[key];
    if (n.empty()) return;
    if (!n.isReal() && !n.isInt()) throw ConfigError(where_ + "." + key + " must be a number");
    *target = static_cast<double>(n);
    if (!std::isfinite(*target)) throw ConfigError(where_ + "." + key + " must be finite");
  }
  void Int(const std::string& key, int* target) {
    known_.push_back(key);
    const cv::FileNode n = node_[key];
    if (n.empty()) return;
    if (!n.isInt()) throw ConfigError(where_ + "." + key + " must be an integer");
    *target = static_cast<int>(n);
  }
  void Bool(const std::string& key, bool* target) {
    int value = *target ? 1 : 0;
    Int(key, &value);
    if (value != 0 && value != 1) throw ConfigError(where_ + "." + key + " must be 0 or 1");
    *target = value == 1;
  }
  void String(const std::string& key, std::string* target) {
    known_.push_back(key);
    const cv::FileNode n = node_[key];
    if (n.empty()) return;
    if (!n.isString()) throw ConfigError(where_ + "." + key + " must be a string");
    *target = static_cast<std::string>(n);
  }
  // Every key of the section must have been asked for.
  void RejectUnknown() const {
    for (const cv::FileNode& child : node_) {
      if (std::find(known_.begin(), known_.end(), child.name()) == known_.end()) {
        throw ConfigError(where_ + "." + child.name() + " is not a known option");
      }
    }
  }

 private:
  cv::FileNode node_;
  std::string where_;
  std::vector<std::string> known_;
};

}  // namespace

void ApplyConfigFile(const std::string& path, RunOptions* o) {
  // A config file that is not there or not readable is bad usage (exit 2), as a bad value
  // in it is.
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw ConfigError("config file not found: " + path);
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw ConfigError("config file is not a regular file: " + path);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError("config file cannot be read (permissions?): " + path);
  std::ostringstream text;
  text << in.rdbuf();
  const cv::FileStorage fs = OpenYamlMap(text.str(), path);
  using Reader = std::function<void(Section*)>;
  RgbdSourceOptions& s = o->source;
  const std::map<std::string, Reader> sections = {
      {"features",
       [&](Section* x) {
         x->Int("max_features", &s.frontend.features.max_features);
         x->Double("contrast_threshold", &s.frontend.features.contrast_threshold);
         x->Double("edge_threshold", &s.frontend.features.edge_threshold);
         x->Int("octave_layers", &s.frontend.features.octave_layers);
         x->Double("image_scale", &s.frontend.features.image_scale);
       }},
      {"matching",
       [&](Section* x) {
         x->Double("ratio", &s.frontend.matching.ratio);
         x->Bool("mutual", &s.frontend.matching.mutual);
       }},
      {"lifting",
       [&](Section* x) {
         x->Int("window_radius", &s.frontend.lifting.window_radius);
         x->Double("sigma_multiplier", &s.frontend.lifting.sigma_multiplier);
         x->Double("footprint_multiplier", &s.frontend.lifting.footprint_multiplier);
         x->Double("edge_sigma_multiplier", &s.frontend.lifting.edge_sigma_multiplier);
         x->Int("min_valid_in_window", &s.frontend.lifting.min_valid_in_window);
       }},
      {"registration",
       [&](Section* x) {
         x->Double("inlier_threshold_m", &s.frontend.registration.inlier_threshold_m);
         x->Int("max_iterations", &s.frontend.registration.max_iterations);
         x->Double("probability", &s.frontend.registration.probability);
         x->Int("min_inliers", &s.frontend.registration.min_inliers);
         x->Double("min_spread_m", &s.frontend.registration.min_spread_m);
         x->Double("inlier_chi2", &s.frontend.registration.inlier_chi2);
         x->Bool("use_point_covariances", &s.frontend.registration.use_point_covariances);
       }},
      {"database",
       [&](Section* x) {
         x->Int("trees", &s.database.trees);
         x->Int("checks", &s.database.checks);
         x->Int("neighbours", &s.database.neighbours);
         x->Double("ratio", &s.database.ratio);
       }},
      {"source",
       [&](Section* x) {
         x->Int("max_base_candidates", &s.max_base_candidates);
         x->Int("max_new_features_per_frame", &s.max_new_features_per_frame);
         x->Int("min_inliers_secondary", &s.min_inliers_secondary);
       }},
      {"selector",
       [&](Section* x) {
         std::string kind = SelectorKindName(o->pipeline.selector.kind);
         x->String("kind", &kind);
         if (!ParseSelectorKind(kind, &o->pipeline.selector.kind)) {
           throw ConfigError(path + ": selector.kind must be info, all, interval or deadreckoning");
         }
         x->Int("buffer", &o->pipeline.selector.buffer_size);
         x->Int("interval", &o->pipeline.selector.interval);
         x->Int("min_common_features", &o->pipeline.selector.min_common_features);
         x->Double("map_gain_threshold", &o->pipeline.selector.map_gain_threshold);
         x->Int("max_recovery_frames", &o->pipeline.selector.max_recovery_frames);
         x->Double("min_view_change_deg", &o->pipeline.selector.min_view_change_deg);
       }},
      {"filter",
       [&](Section* x) {
         x->Double("anchor_information", &o->pipeline.filter.anchor_information);
         x->Bool("iterative_recovery", &o->pipeline.filter.iterative_recovery);
         x->Double("cg_tolerance", &o->pipeline.filter.cg_tolerance);
         x->Int("max_dense_pose_dim", &o->pipeline.filter.max_dense_pose_dim);
       }},
      {"map",
       [&](Section* x) {
         x->Double("voxel_size_m", &o->map.voxel_size_m);
         x->Int("pixel_step", &o->map.pixel_step);
       }},
      {"ba",
       [&](Section* x) {
         std::string loss = BaRobustLossName(o->pipeline.ba.robust_loss);
         x->String("robust_loss", &loss);
         if (!ParseBaRobustLoss(loss, &o->pipeline.ba.robust_loss)) {
           throw ConfigError(path + ": ba.robust_loss must be none or huber, got '" + loss + "'");
         }
         x->Double("huber_scale", &o->pipeline.ba.huber_scale);
         x->Double("rejection_chi2", &o->pipeline.ba.rejection_chi2);
         x->Int("max_rejection_rounds", &o->pipeline.ba.max_rejection_rounds);
         x->Int("max_iterations", &o->pipeline.ba.max_iterations);
       }},
      {"depth_alignment",
       [&](Section* x) {
         DepthAlignmentOptions& d = o->pipeline.depth_alignment;
         x->Int("rounds", &d.rounds);
         x->Int("grid_step", &o->range_cloud.step);
         x->Int("sample_step", &d.sample_step);
         x->Double("initial_gate_m", &d.initial_gate_m);
         x->Double("final_gate_m", &d.final_gate_m);
         x->Double("max_normal_angle_deg", &d.max_normal_angle_deg);
         x->Double("huber_sigmas", &d.huber_sigmas);
         x->Double("min_overlap", &d.min_overlap);
         x->Double("max_robust_sigma", &d.max_robust_sigma);
         x->Int("max_partners", &d.max_partners);
       }},
  };
  const cv::FileNode root = fs.root();
  for (const cv::FileNode& node : root) {
    const auto it = sections.find(node.name());
    if (it == sections.end()) {
      throw ConfigError(path + ": unknown section '" + node.name() + "'");
    }
    if (!node.isMap()) throw ConfigError(path + ": section '" + node.name() + "' must be a map");
    Section section(node, path + ": " + node.name());
    it->second(&section);
    section.RejectUnknown();
  }
  std::string why;
  if (!o->source.Check(&why) || !o->pipeline.selector.Check(&why) ||
      !o->pipeline.filter.Check(&why) || !o->map.Check(&why) || !o->pipeline.ba.Check(&why) ||
      !o->range_cloud.Check(&why) || !o->pipeline.depth_alignment.Check(&why)) {
    throw ConfigError(path + ": " + why);
  }
}

}  // namespace ieslam
