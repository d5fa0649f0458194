// Mapping on from a saved map (`ieslam run --map`): the map's keyframes followed by a dataset's
// frames, as one dataset, and what the pipeline resumes from.
//
// Frame k < map_frames() is the map's keyframe k (keyframes enter a map in time order), with
// the timestamp, dataset index and ground truth the map keeps, and its images when the mapping
// run's dataset is where the map says (map_images()). Frames map_frames() .. are the dataset's,
// in its order. Numbered that way, every frame of the continued run is one index of one
// dataset, as a run's outputs expect.
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
  // True when the map's frames have their images: the mapping run's dataset (SavedMap::dataset,
  // opened with the map's dataset options) is there, with the map's calibration, and holds
  // each keyframe's frame at its timestamp. Otherwise why not, for a warning.
  bool map_images() const { return map_images_missing_.empty(); }
  const std::string& map_images_missing() const { return map_images_missing_; }

  // The map's keyframes into `source` as its base frames, and the map's feature ids as taken.
  void AddBaseFrames(RgbdFrameSource* source) const;
  // The filter and the selection to go on from, with the keyframes renumbered.
  PipelineResume Resume() const;

 private:
  const LoadedMap& map_;
  std::string format_;
  double timestamp_shift_s_ = 0.0;
  std::string map_images_missing_;

  // The image paths of the map's frames from the mapping run's dataset, or the reason in
  // map_images_missing_.
  void FindMapImages();
};

}  // namespace ieslam
