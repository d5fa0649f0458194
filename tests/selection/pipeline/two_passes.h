// The synthetic sequences the saved-map tests share: a hand-held pass through a room and a second
// pass along another path through the same room.
#pragma once

#include <Eigen/Core>

#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {

// 40 frames of hand-held motion: ~2 cm and ~1.5 deg per frame.
inline SyntheticDatasetOptions FirstPass() {
  SyntheticDatasetOptions options;
  options.frames = 40;
  options.frames_per_loop = 300;
  return options;
}

// The first pass 5 cm lower, 5 cm further in and with other noise; its timestamps are the first
// pass's, as those of another recording may be.
inline SyntheticDatasetOptions SecondPass() {
  SyntheticDatasetOptions options = FirstPass();
  options.trajectory.height_m -= 0.05;
  options.trajectory.radii_m -= Eigen::Vector2d(0.05, 0.05);
  options.noise_seed = 7;
  return options;
}

}  // namespace ieslam
