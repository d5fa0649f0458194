// Localisation in a saved map (`ieslam localize`): each frame is placed in the map's frame
// through the selector's recovery path, fed by the map instead of a running selection. The
// map's base frames go into one descriptor database; a frame is registered exactly (ratio +
// mutual matching, RANSAC) to the base frames the database ranks first and to the one that
// placed the frame before it; the inlier matches of every base frame that registers are
// pooled, each matched base keypoint standing for its map feature's position (or, for a
// keypoint that is no feature, a pending one included, or with the refined poses, for its
// lifted point at its keyframe's pose), and one RANSAC over the pool gives the frame's pose in the
// map. Nothing is added to the map.
//
// Tracking bridges views the map does not cover: the frame placed before is registered as
// well and its matches join the pool after the map's (a keypoint matched in both stands for
// the map's point), so that where the map's views are narrow its many close matches steady
// the fit, and where the map gives too few inliers the frame is placed relative to the one
// before it (ORB-SLAM2's localisation mode falls back on visual odometry the same way). Such
// a frame is counted apart (LocalizedFrame::by_map false), its covariance grows along the
// chain, and after max_tracked_frames frames without the map the chain ends.
//
// The pose's covariance is the fit's, from both views' point noise (the frame's lifted
// points and the base keypoints'), plus what the best base keyframe's own marginal
// covariance makes of the pose: a map's errors are correlated, so the fit against many of its
// features does not average them away, and the keyframe stands for that shared error.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/dataset.h"
#include "core/option_table.h"
#include "core/pose.h"
#include "frontend/frame_prefetcher.h"
#include "frontend/frame_processor.h"
#include "frontend/matcher.h"
#include "frontend/rgbd_frame_source.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

struct LocalizeOptions {
  // Base frames the database ranks first that a frame is registered to (the one that placed
  // the frame before it is tried as well): each costs one exact match and RANSAC.
  int candidates = 3;
  // A base frame other than the best one adds its inliers to the pool only with at least this
  // many (as a secondary view does in the run).
  int min_inliers_secondary = 15;
  // Place frames against the map's refined keyframes (a run with --refine) instead of the
  // filter's poses and features. The map keeps no refined features, so each base keypoint then
  // stands for its own lifted point at the refined pose; the refinement also fits the range
  // clouds, to which those single-view points need not agree, and away from the keyframes the
  // mismatch grows. Off by default: the filter's poses and features are one estimate.
  bool refined_poses = false;
  // While the map placed the frame before, a frame is first registered to the base frame that
  // did; with this many inliers the database's candidates are not tried (each costs an exact
  // match and RANSAC, and a pose from 50 spread inliers is already well determined).
  int track_inliers = 50;
  // Frames, placed or not, after the map last placed one that tracking alone may place (3 s
  // of 30 Hz data: the odometry of these sequences drifts by a few centimetres in that time);
  // 0 turns tracking off.
  int max_tracked_frames = 90;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<LocalizeOptions>& Table();
  bool Check(std::string* why) const { return Table().Check(*this, why); }
};

struct LocalizedFrame {
  int frame = -1;
  double timestamp = 0.0;
  bool localized = false;
  std::string reason;  // why not, when !localized
  Eigen::Isometry3d T_map_c = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Zero();  // of core/pose.h's 6-vector of T_map_c
  // Placed by the map: at least a registration's min_inliers of the fit's inliers are the
  // map's (else by tracking from the frame placed before).
  bool by_map = false;
  int base_keyframe = -1;          // the best base frame (map keyframe index), when by_map
  int base_frames_registered = 0;  // base frames (and the frame before) whose inliers pooled
  int inliers = 0;                 // of the pooled fit
  int map_inliers = 0;             // of those, matches of the map's base frames
  int map_features = 0;            // of those, features of the map
};

// Places frames in one map. Holds the map's base frames as processed frames and their
// descriptors in a database; not thread-safe (one frame at a time, in order).
class MapLocalizer {
 public:
  // `map` must outlive the localizer. Throws ConfigError for options failing their checks.
  MapLocalizer(const SavedMap& map, const FrontendOptions& frontend,
               const DatabaseOptions& database, const LocalizeOptions& options);
  ~MapLocalizer();
  MapLocalizer(const MapLocalizer&) = delete;
  MapLocalizer& operator=(const MapLocalizer&) = delete;

  // The frame placed in the map, or why not (frame.localized false). A frame's placement
  // depends on the frames before it through the base frame that placed the last one (tried
  // first), the last placed frame (pooled with the map's matches, and the anchor when tracked)
  // and the count of frames tracked since the map last placed one.
  LocalizedFrame Localize(const ProcessedFrame& frame);

  // Whether frames are placed against the refined keyframes (LocalizeOptions::refined_poses).
  bool uses_refined_poses() const { return refined_; }
  // Frames the database was asked for candidates for (the others were tracked).
  int database_queries() const { return database_queries_; }
  double seconds_match() const { return seconds_match_; }
  double seconds_ransac() const { return seconds_ransac_; }

  // One pooled correspondence: a frame keypoint and the map point its base match stands for.
  struct PoolEntry {
    int row = -1;  // the frame's keypoint row
    Eigen::Vector3d p_map = Eigen::Vector3d::Zero();
    Eigen::Matrix3d cov_map = Eigen::Matrix3d::Zero();  // the base keypoint's noise, in the map
    double sigma_d = 0.0;                               // sqrt of both points' range variances
    bool map = false;      // from a map base frame (not the previous frame)
    bool feature = false;  // a feature of the map
  };

 private:
  // The candidate id of the previous frame.
  static constexpr int kPrevious = -2;

  // The base frames the database ranks first for `frame`, and the one that last placed one.
  std::vector<int> Candidates(const ProcessedFrame& frame);
  // The map's base frames that `frame` registers to, most inliers first.
  std::vector<std::pair<int, FrameRegistration>> RegisterToMap(const ProcessedFrame& frame);
  // Adds the inliers of `base` not pooled yet.
  void AddToPool(int base, const FrameRegistration& registration, const ProcessedFrame& frame,
                 std::vector<PoolEntry>* pool, std::vector<char>* pooled) const;
  RegistrationResult FitPool(const std::vector<PoolEntry>& pool, const ProcessedFrame& frame) const;
  // Fills *out from the pool's fit (out->by_map set) and keeps the frame for tracking. `best`
  // is the map keyframe with most inliers.
  void Place(const RegistrationResult& result, const std::vector<PoolEntry>& pool,
             const ProcessedFrame& frame, int best, LocalizedFrame* out);

  const SavedMap& map_;
  FrontendOptions frontend_;
  LocalizeOptions options_;
  std::vector<ProcessedFrame> bases_;  // one per map keyframe
  bool refined_ = false;
  std::vector<Eigen::Isometry3d> base_poses_;  // the keyframes' poses frames are placed by
  // Per base frame and keypoint: the index into map_.features of the feature it observes, or -1.
  std::vector<std::vector<int>> base_feature_index_;
  BaseFrameDatabase database_;
  int last_base_ = -1;  // the base keyframe that last placed a frame
  int since_map_ = 0;   // frames since the map last placed one
  bool has_previous_ = false;
  ProcessedFrame previous_;  // the frame placed before, its pose and covariance
  Eigen::Isometry3d previous_pose_ = Eigen::Isometry3d::Identity();
  Matrix6d previous_covariance_ = Matrix6d::Zero();
  int database_queries_ = 0;
  double seconds_match_ = 0.0;
  double seconds_ransac_ = 0.0;
};

// Hooks into LocalizeDataset; every one optional.
struct LocalizeHooks {
  std::function<void(int done, int localized)> progress;
  std::function<bool()> stop;  // polled between frames: true ends the run there
};

struct LocalizeTimings {
  double fetch_wall = 0.0;  // the caller's thread getting processed frames (load, SIFT, lift)
  double load = 0.0, extract = 0.0, lift = 0.0;  // summed over the frames, on any thread
  double match = 0.0, ransac = 0.0;
  double setup = 0.0;  // building the localizer's database from the map
  double total = 0.0;
};

struct LocalizeResult {
  std::vector<LocalizedFrame> frames;  // every processed frame, in order
  int localized = 0;
  int localized_by_map = 0;
  // Frames placed right after one or more that were not: tracking regained.
  int resumptions = 0;
  bool interrupted = false;
  bool refined_poses = false;  // placed against the refined keyframes
  int database_queries = 0;    // frames the database ranked base frames for
  LocalizeTimings seconds;
  // A rolling-shutter rig's frames: how many had a velocity from both neighbours, one, none.
  std::optional<FrameVelocities::Counts> velocity_counts;
};

// Localises every frame of `dataset` in `map` with the front end of `source` (its frontend and
// database options; frames processed ahead on source.prefetch.workers threads; a rolling-shutter
// rig's frames compensated as the mapping run's were, source.velocity_max_step_s). A frame that
// does not load, or has too few lifted keypoints, is a frame not placed, with the reason.
LocalizeResult LocalizeDataset(const Dataset& dataset, const SavedMap& map,
                               const RgbdSourceOptions& source, const LocalizeOptions& options,
                               const LocalizeHooks& hooks);

// The map-frame ground truth of a localisation: the rigid transform from the ground truth's
// frame to the map's, fitted (Horn) between the map's keyframe positions and their ground
// truth as the mapping run had it, so that localised frames are judged in the map's frame with
// no alignment of their own (valid for a dataset whose ground truth shares the mapping
// dataset's frame: the same recording, a motion-capture room, a synthetic scene). The
// keyframes' refined poses are used when `refined` (those the frames were placed by). The fit
// uses the keyframes' positions alone, as the ATE does; over a map whose keyframes barely move
// (a camera turning in place) its rotation is poorly determined, which `rmse_m` does not show.
struct MapFrameAlignment {
  bool ok = false;
  std::string reason;  // why not, when !ok
  Eigen::Isometry3d T_map_gt = Eigen::Isometry3d::Identity();
  // The same through the map's first keyframe alone, where the map's covariances have their
  // origin (its pose is the map's gauge): what a stated covariance is judged against. Only when
  // that keyframe has ground truth (`has_origin`).
  bool has_origin = false;
  Eigen::Isometry3d T_map_gt_origin = Eigen::Isometry3d::Identity();
  int keyframes = 0;    // map keyframes with ground truth
  double rmse_m = 0.0;  // the keyframes' residual after the fit
};
MapFrameAlignment AlignMapToGroundTruth(const SavedMap& map, bool refined);

}  // namespace ieslam
