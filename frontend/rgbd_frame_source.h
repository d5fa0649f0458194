// The selector's view of a real sequence (core/frame_source.h): frames go through the front
// end once (SIFT, lifting; the processed frames are kept until released, so dropped frames
// can be matched again for recovery), candidates are matched against the base-frame database
// (FLANN) and registered exactly (ratio + mutual matching, RANSAC) to the best-ranked base frames.
//
// Data association follows the paper: a frame's keypoint inherits the feature id of the base
// frame keypoint it is an inlier match of; when the frame enters the filter, its unmatched
// lifted keypoints become new features (the strongest first, at most
// max_new_features_per_frame of them, which bounds the state's growth). SIFT's keypoints at
// one position with different orientations are one feature, observed once. Ids are handed
// out here whether or not the filter takes the feature into its state at once: with delayed
// initialisation (InformationFilterOptions::min_sightings) it waits for a later frame's
// match to the keypoint, which carries the same id.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/dataset.h"
#include "core/frame_source.h"
#include "core/option_table.h"
#include "frontend/frame_prefetcher.h"
#include "frontend/frame_processor.h"
#include "frontend/rolling_shutter.h"

namespace ieslam {

struct RgbdSourceOptions {
  FrontendOptions frontend;
  DatabaseOptions database;
  // Base frames ranked by the database that are registered exactly; the last base frame is
  // always tried as well. Every further base frame that registers adds its observations of
  // the map's features (multi-view constraints and loop closures) for the cost of one more
  // registration (8 against 4: docs/frontend_notes.md).
  int max_base_candidates = 8;
  int max_new_features_per_frame = 100;
  // A base frame other than the best one adds its inliers' observations only when its own
  // registration has at least this many inliers (loop closures through a second view).
  int min_inliers_secondary = 15;
  // Frames loaded and processed ahead on worker threads (0 workers: sequential).
  PrefetchOptions prefetch;
  // Threads that register a frame to its base candidates (up to max_base_candidates and the
  // last base frame), the caller's among them, at most one per registration (set from the
  // run's threads, like the prefetch workers); any number gives the same registrations.
  int registration_threads = 1;
  // A rolling-shutter rig's frames are compensated with the velocity their registrations to
  // the frames next to them give (frontend/rolling_shutter.h). Frames further apart in time
  // than this say nothing of each other's velocity: three frame periods at 30 Hz (a stride of
  // 3, or one frame skipped) still give the velocity at the frame; over longer gaps a hand-held
  // camera's velocity changes as much as it is.
  double velocity_max_step_s = 0.1;

  // The options' registration: keys, help, checks (core/option_table.h).
  static const OptionTable<RgbdSourceOptions>& Table();
  bool Check(std::string* why) const;
};

// Seconds the source spent in each front-end stage, summed over the frames it processed.
struct SourceTimings {
  double extract_s = 0.0;
  double lift_s = 0.0;
  double match_s = 0.0;
  double ransac_s = 0.0;
  double load_s = 0.0;
  // Adding committed frames' descriptors to the base frame database (their copy, and the
  // search index rebuilt as the database grows), on the caller's thread.
  double database_s = 0.0;
  // Wall time the caller's thread spent getting processed frames: all of load + extract +
  // lift when sequential, only the waits when workers prefetch.
  double fetch_wall_s = 0.0;
  // How far match_s + ransac_s of the registrations run on several threads exceed the
  // caller's wall time spent on them (their overlap).
  double parallel_overlap_s = 0.0;
  double total() const { return extract_s + lift_s + match_s + ransac_s + load_s + database_s; }
  // The front end's share of the caller's thread (what selection time must not include).
  double caller() const {
    return fetch_wall_s + match_s + ransac_s + database_s - parallel_overlap_s;
  }
};

class RgbdFrameSource : public FrameSource {
 public:
  // Frames before `first_prepared` are not loaded ahead: they are base frames to be added
  // (AddBaseFrame), or frames nobody asks for.
  RgbdFrameSource(const Dataset& dataset, const RgbdSourceOptions& options, int first_prepared = 0);
  ~RgbdFrameSource() override;

  int size() const override { return dataset_.size(); }
  double timestamp(int frame) const override { return dataset_.info(frame).timestamp; }
  CandidateFrame PrepareFirst(int frame) override;
  CandidateFrame Prepare(int frame) override;
  CandidateFrame PrepareAgainst(int frame, int base_frame) override;
  void Commit(const CandidateFrame& candidate) override;
  // Frees the processed frame (features, lifted points) and its cached registrations; a
  // base frame stays.
  void Release(int frame) override;
  // Frees every processed frame, registration and the descriptor database; preparing or
  // committing a frame afterwards is a programming error (checked).
  void Finish() override;
  // Hands base frame `frame` over, before Finish: its processed frame and the feature id of
  // each of its keypoint rows (-1: a keypoint that is no feature). The source keeps nothing
  // of it and must not be asked to register against it again (checked).
  std::pair<ProcessedFrame, std::vector<int64_t>> TakeBaseFrame(int frame);
  // Takes `frame` as a base frame that entered the filter before this source existed (a saved
  // map's, for mapping to go on from it): its processed frame and the feature id of each
  // keypoint row (-1: no feature). New features get ids above every id seen. Before any
  // frame is prepared, and once per frame (checked).
  void AddBaseFrame(int frame, ProcessedFrame processed, std::vector<int64_t> feature_ids);
  // New features get ids from `id` up at least (those below are taken: a saved map's
  // features that no base-frame row names any more).
  void ReserveFeatureIdsBelow(int64_t id) { next_feature_id_ = std::max(next_feature_id_, id); }
  // A base frame that TakeBaseFrame can hand over.
  bool HasBaseFrame(int frame) const {
    return feature_ids_.count(frame) > 0 && processed_.count(frame) > 0;
  }

  const SourceTimings& timings() const { return timings_; }
  // The frames' velocities for rolling-shutter compensation; none when the rig's colour camera
  // has a global shutter.
  const FrameVelocities* velocities() const { return velocities_.get(); }
  // The processed frame (features and lifted points), processing it now if needed. A frame
  // whose images do not load (missing, corrupt, wrong size), whose range image has no valid
  // measurement, or with too few lifted keypoints to register (textureless) is processed as
  // an empty frame and is unusable: its candidates are never registered and carry the
  // reason, so one bad frame is a counted skip rather than the end of the run.
  const ProcessedFrame& Processed(int frame);
  // Processed frames held: the base frames, those processed and not released, and those
  // fetched ahead for a rolling-shutter neighbour's velocity.
  int frames_kept() const { return static_cast<int>(processed_.size() + fetched_ahead_.size()); }
  // Why `frame` is unusable (see Processed), or "" when it is usable or not processed yet.
  std::string UnusableReason(int frame) const;

 private:
  // The frame as the front end made it (prefetched, or processed now), before rolling-shutter
  // compensation; an unusable frame is empty and has its reason in unusable_.
  ProcessedFrame Fetch(int frame);
  // Moves the keypoints of a rolling-shutter frame into the view of its timestamp.
  void Compensate(int frame, ProcessedFrame* processed);
  // T_{k-1,k} from the frames' registration, the frames not compensated unless already so.
  std::optional<Eigen::Isometry3d> RegisterStep(int later);
  CandidateFrame Build(int frame, const std::vector<int>& bases);
  // The candidate of an unusable frame: not registered, with the reason.
  CandidateFrame Unusable(int frame) const;
  // `frame`'s registration to each of `bases`, in their order (cached per pair).
  std::vector<FrameRegistration> Register(const std::vector<int>& bases, int frame);

  const Dataset& dataset_;
  RgbdSourceOptions options_;
  FrameProcessor processor_;
  BaseFrameDatabase database_;
  FramePrefetcher prefetcher_;
  std::map<int, ProcessedFrame> processed_;
  // Frames fetched to register a neighbour's step before they were asked for themselves (not
  // compensated yet); each leaves when it is processed or released.
  std::map<int, ProcessedFrame> fetched_ahead_;
  std::unique_ptr<FrameVelocities> velocities_;  // rolling-shutter rigs only
  std::map<int, std::string> unusable_;          // frame -> why (see Processed)
  // A frame is prepared again in each buffer that holds it: its registrations to base
  // frames do not change, so they are computed once. Entries of frames that became base
  // frames or fell behind are dropped (see Commit).
  std::map<std::pair<int, int>, FrameRegistration> registrations_;  // (base, frame)
  std::map<int, std::vector<int64_t>> feature_ids_;  // per base frame: id per keypoint row
  std::map<int, std::vector<int64_t>> pending_;      // per prepared frame: tentative ids
  int64_t next_feature_id_ = 0;
  int last_base_ = -1;
  bool finished_ = false;
  bool handed_over_ = false;  // a base frame was taken (TakeBaseFrame)
  SourceTimings timings_;
};

}  // namespace ieslam
