// Mapping on from a saved map (`ieslam run --map`): the map's keyframes followed by a dataset's
// frames, as one dataset, and what the pipeline resumes from.
//
// Frame k < map_frames() is the map's keyframe k (keyframes enter a map in time order), with
// the timestamp and ground truth the map keeps, and its images where its origin is still there
// (has_images). Frames map_frames() .. are the dataset's, in its order. Numbered that way,
// every frame of the continued run is one index of one dataset, as a run's outputs expect.
#pragma once

#include <string>
#include <vector>

#include "core/dataset.h"
#include "frontend/rgbd_frame_source.h"
#include "selection/pipeline/pipeline.h"
#include "selection/pipeline/saved_map.h"

namespace ieslam {

class ContinuedDataset : public Dataset {
 public:
  // `map` must outlive this dataset. Throws DataError naming the map's file when the map
  // holds no keyframe, its keyframes are not in time order, or it was made with another
  // calibration than `next`'s (CheckMapCalibration). When the dataset's first frame is not
  // later than the map's last keyframe (another recording numbered from zero), the dataset's
  // timestamps are shifted to follow the map's by one second, with a warning: its frames and
  // ground truth move together.
  ContinuedDataset(const LoadedMap& map, const Dataset& next, const DatasetOptions& options);

  std::string format() const override { return format_; }
  int map_frames() const { return static_cast<int>(map_.map.keyframes.size()); }
  const LoadedMap& map() const { return map_; }
  // Seconds added to the dataset's timestamps (0 unless shifted).
  double timestamp_shift_s() const { return timestamp_shift_s_; }
  // Whether frame `frame` has its images: every frame of the dataset, and each map keyframe
  // whose origin (FrameOrigin: opened with the map's dataset options) is there, with the map's
  // calibration, and holds the keyframe's frame at its timestamp. The constructor opens each
  // origin dataset once to find out.
  bool has_images(int frame) const { return frame >= map_frames() || map_images_[frame]; }
  int map_frames_without_images() const;
  // Why map keyframes have no images (one reason per dataset), or empty.
  const std::string& map_images_missing() const { return map_images_missing_; }
  // Where frame `frame` came from, for the map a continued run saves.
  FrameOrigin origin(int frame) const;

  // The map's keyframes into `source` as its base frames, and the map's feature ids as taken.
  void AddBaseFrames(RgbdFrameSource* source) const;
  // The filter and the selection to go on from, with the keyframes renumbered.
  PipelineResume Resume() const;

 private:
  const LoadedMap& map_;
  std::string format_;
  double timestamp_shift_s_ = 0.0;
  std::vector<bool> map_images_;  // per map keyframe
  std::string map_images_missing_;

  // The image paths of the map's frames from their origins, and the reasons for those not found.
  void FindMapImages();
};

}  // namespace ieslam
