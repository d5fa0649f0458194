// The tests' short version of the paper's simulation: one loop of 80 poses.
#pragma once

#include <cstdint>

#include "frontend/simulation/paper_simulation.h"

namespace ieslam {
namespace testing_selection {

inline SimulatedDataset ShortPaperSimulation(bool noise, uint32_t noise_seed = 2) {
  SimulationOptions options;
  options.trajectory.num_poses = 80;
  options.trajectory.num_loops = 1;
  options.add_noise = noise;
  options.noise_seed = noise_seed;
  return SimulatePaperScenario(options);
}

}  // namespace testing_selection
}  // namespace ieslam
