// A map that outlives its run: what `ieslam run` writes to OUT/map/, for a later session to
// localise in or to go on mapping from.
//
// It holds the base-frame database (each keyframe's lifted keypoints with their descriptors
// and the map feature each one is), the keyframes' poses (the filter's with their marginal
// covariances and, after a refinement, the refined ones, and the observations each entered
// the filter with), the features with their marginal covariances, the filter's information
// matrix, vector and state exactly as they stand (so that mapping resumes from the same
// estimate, its pending features' sightings included), and the calibration and options it
// was made with.
//
// On disk: OUT/map/map.bin, a section file (core/section_file.h) with magic "IESLAMAP",
// format version kMapFormatVersion, and the sections META, KFRM, FEAT, BASE and FILT in that
// order (the README documents their fields).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "backend/information_filter.h"
#include "backend/slam_estimate.h"
#include "core/calibration.h"
#include "core/observation.h"
#include "core/pose.h"
#include "frontend/features.h"
#include "frontend/frame_processor.h"
#include "frontend/lifting.h"
#include "selection/pipeline/refinement.h"

namespace ieslam {

inline constexpr uint32_t kMapFormatVersion = 4;
inline constexpr char kMapDirectory[] = "map";
inline constexpr char kMapFileName[] = "map.bin";

// One base frame as the front end holds it: row i of `features` is the keypoint lifted to
// points[i], and is map feature feature_ids[i] (-1: a keypoint that is no feature of the map).
struct MapBaseFrame {
  int frame = -1;  // the frame's index in the mapping run
  double timestamp = 0.0;
  FrameFeatures features;
  std::vector<LiftedPoint> points;
  std::vector<int64_t> feature_ids;
};

// Where a keyframe's frame came from, so that a later session can read its images again: the
// dataset's directory (absolute), the frame's index there (FrameInfo::source_index) and its
// timestamp there (before any shift a continued run applied).
struct FrameOrigin {
  std::string dataset;
  int source_index = -1;
  double timestamp = 0.0;
};

struct MapKeyframe {
  int frame = -1;  // its index in the mapping run's frames
  FrameOrigin origin;
  double timestamp = 0.0;                    // in the mapping run
  Vector6d pose = Vector6d::Zero();          // the filter's, camera-to-world (core/pose.h)
  Matrix6d covariance = Matrix6d::Zero();    // its marginal covariance
  bool refined = false;                      // the run was refined
  Vector6d refined_pose = Vector6d::Zero();  // the refinement's, when refined
  // The mapping dataset's ground truth of the frame, when it has one (camera-to-world in the
  // ground truth's frame): what places the map's frame in the ground truth's for a later
  // localisation in it.
  bool has_ground_truth = false;
  Vector6d ground_truth = Vector6d::Zero();
  // The observations the keyframe entered the filter with (after the filter's gate): what a
  // continued run's bundle adjustment takes up for it.
  std::vector<FeatureObservation> observations;
};

struct MapFeature {
  int64_t id = -1;
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // its marginal covariance
};

// The filter as it stands (InformationFilter::Snapshot; Restore takes it over).
using MapFilterState = FilterSnapshot;

struct SavedMap {
  std::string version;                    // of the ieslam that wrote it
  std::string calibration;                // FormatCalibration of the rig
  std::string options;                    // the run's options as a config file
  std::string dataset;                    // the last mapping run's dataset, as its report names it
  std::vector<MapKeyframe> keyframes;     // in the order they entered the filter
  std::vector<MapFeature> features;       // in the order they entered the filter
  std::vector<MapBaseFrame> base_frames;  // one per keyframe, in the same order
  MapFilterState filter;
};

// The map of a run: `filter` holds the selected poses and features, `estimate` is its
// estimate (FilterEstimate: the pose covariances are taken from it where it has them),
// `base_frames` the keyframes' processed frames (one per filter pose, in the filter's order),
// `observations` the observations each filter pose entered with (SelectionResult's);
// `refinement` the refined estimate or nullptr. Feature ids of base-frame rows that the
// filter does not know (neither in its state nor pending) become -1. The features' marginal
// covariances come from the filter's factor, a few hundred features per recovery.
SavedMap MakeSavedMap(const InformationFilter& filter, const SlamEstimate& estimate,
                      std::vector<MapBaseFrame> base_frames,
                      const std::map<int, std::vector<FeatureObservation>>& observations,
                      const Refinement* refinement, const Rig& rig, const std::string& options,
                      const std::string& dataset);

// Writes `map` to `dir`/map.bin atomically (`dir` must exist). Throws OutputError naming the
// file when it cannot be written.
void WriteSavedMap(const std::string& dir, const SavedMap& map);

// Reads `dir`/map.bin. Throws DataError naming the file and what is wrong: missing, not a map,
// another format version, truncated, a checksum that does not match, or contents that do not
// hold together (counts, offsets, ids, sizes).
SavedMap ReadSavedMap(const std::string& dir);

// The directory holding a map file: `dir` itself, or `dir`/map when `dir` is a run's output
// directory (and holds no map file itself).
std::string FindMapDirectory(const std::string& dir);

// A saved map as a later session reads it.
struct LoadedMap {
  std::string directory;  // holding the map file (FindMapDirectory)
  SavedMap map;
  double load_seconds = 0.0;  // reading and checking it
  std::string file() const;
};

// FindMapDirectory(path), then ReadSavedMap, timed. Throws as ReadSavedMap.
LoadedMap LoadMap(const std::string& path);

// Frame `frame` of `dataset` as a keyframe's origin, its timestamp less `shift_s` (what a
// continued run added to the dataset's).
FrameOrigin OriginIn(const Dataset& dataset, int frame, double shift_s = 0.0);

// The base frame as the front end holds it, as frame `info`.
ProcessedFrame ProcessedBaseFrame(const MapBaseFrame& base, const FrameInfo& info);

// Throws DataError naming `dir`'s map file unless `map` was made with `rig`'s calibration (a
// map made through other optics places nothing right).
void CheckMapCalibration(const SavedMap& map, const Rig& rig, const std::string& dir);

}  // namespace ieslam
