// Synthetic datasets with exact ground truth: the room of frontend/simulation/synthetic_scene.h
// seen along the loop of frontend/simulation/synthetic_trajectory.h by one of two sensor set-ups,
// written in a layout OpenDataset (core/dataset.h) reads.
//
// Sensors (SyntheticRig):
//  - rgbd: a Kinect-like camera, 640x480 colour and depth registered to it (same intrinsics
//    fx = fy = 525, cx = 319.5, cy = 239.5). Depth holds z, 16-bit PNG in the TUM convention
//    (raw / 5000 = metres), valid in [0.4, 4.5] m, noise sigma(z) = 0.0002 + 0.0016 z^2: the
//    a + c z^2 fit (as data/calib/tum_fr*.yaml) to Nguyen et al. (2012)'s
//    0.0012 + 0.0019 (z - 0.4)^2 (docs/frontend_notes.md); core/camera.h's noise model
//    cannot hold Nguyen's form (its b would be negative), and the data are generated with
//    exactly the model calib.yaml states, so an estimator's covariances are the truth.
//  - pair: the paper's package, a 1024x768 colour camera (fx = fy = 800, 65 x 51 deg) plus a
//    176x144 time-of-flight range imager (fx = fy = 225, 43 x 35 deg like an SR-3000) mounted
//    5 cm to the colour camera's right and turned by ~0.5 deg. Range is the radial distance
//    along each pixel's ray (DepthKind::kRadial, as the SR-3000 reports), 16-bit millimetres,
//    valid in [0.3, 7.5] m, sigma(d) = 0.005 + 0.01 d.
//  Both: pixels whose ray meets the surface at more than max_incidence_deg read 0.
//
// Layouts (timestamps start_time_s + i / frame_rate_hz, printed with 6 decimals, as <t>):
//  - rgbd (TUM): rgb.txt, depth.txt (`timestamp path` with TUM's three comment lines),
//    rgb/<t>.png, depth/<t>.png, groundtruth.txt, calib.yaml.
//  - pair (core/dataset.h): colour.txt, range.txt, colour/<t>.png, range/<t>.png,
//    groundtruth.txt, calib.yaml.
//  groundtruth.txt is the TUM trajectory of the colour camera (T_w_c) at every frame.
//  Both also get synthetic.txt, the options used (FormatSyntheticOptions).
// Every file is written atomically; images first, the lists last, so a directory whose
// lists exist is complete.
//
// Determinism: the same options give byte-identical files whatever `threads` is. The scene
// depends only on scene.seed, the noise of frame i only on (noise_seed, i).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/camera.h"
#include "frontend/simulation/scene_renderer.h"
#include "frontend/simulation/synthetic_scene.h"
#include "frontend/simulation/synthetic_trajectory.h"

namespace ieslam {

enum class SyntheticSensor { kRgbd, kPair };

const char* ToString(SyntheticSensor sensor);
// "rgbd" or "pair"; throws ConfigError naming the value otherwise.
SyntheticSensor ParseSyntheticSensor(const std::string& name);

struct SyntheticDatasetOptions {
  SyntheticSensor sensor = SyntheticSensor::kRgbd;
  int frames = 300;
  // Frames of one loop of the trajectory: 0 (the default) makes `frames` one closed loop; a
  // larger value keeps the per-frame motion of a loop that long and writes only its first
  // `frames` frames (short sequences for tests).
  int frames_per_loop = 0;
  double frame_rate_hz = 30.0;
  double start_time_s = 1000.0;
  // Scales both cameras' resolution and intrinsics (0.25: a 160x120 rgbd dataset for fast
  // tests). calib.yaml always describes the images actually written.
  double resolution_scale = 1.0;
  bool add_noise = true;            // range noise, and colour noise of colour_noise_sigma
  double colour_noise_sigma = 1.0;  // grey levels
  double max_incidence_deg = 75.0;
  int edge_supersampling = 2;  // RenderOptions::edge_supersampling
  // Threads (0: all cores) over the rows of a frame in RenderSyntheticFrame, over whole
  // frames in WriteSyntheticDataset. Never changes the output.
  int threads = 0;
  uint32_t noise_seed = 2;
  // Rolling shutter of the rgbd sensor (Rig::colour_readout_s): each row of the colour and the
  // registered depth image is rendered from the camera's pose at that row's time; 0 renders a
  // global shutter. calib.yaml carries it.
  double readout_s = 0.0;
  // The range imager's systematic error (RangeImager::depth_correction): each depth is
  // rendered times its pixel's factor. calib.yaml carries it; a run with a calibration
  // without it sees a depth tilted as a real Kinect's can be. All 0: none.
  std::array<double, 3> depth_correction{};
  SyntheticSceneOptions scene;  // scene.seed picks the scene
  SyntheticTrajectoryOptions trajectory;

  bool Check(std::string* why) const;
};

// The rig of `sensor` (see above) at `resolution_scale`.
Rig SyntheticRig(SyntheticSensor sensor, double resolution_scale = 1.0);

// One frame, with the exact geometry behind it.
struct SyntheticFrame {
  double timestamp = 0.0;
  Eigen::Isometry3d T_w_c = Eigen::Isometry3d::Identity();  // colour camera
  cv::Mat colour;            // CV_8UC3 BGR, noise added as the options say
  cv::Mat range_raw;         // CV_16UC1 raw values in the range imager's grid (rig.range)
  RenderedView colour_view;  // exact geometry and noise-free colour of the colour camera
  RenderedView range_view;   // exact geometry of the range imager (rgbd: colour_view's)
};

// Renders frame `index` (its noise seeded by noise_seed and index) at pose T_w_c of the
// colour camera, or, given T_w_c_of_row, each row of the colour image (and of a registered
// range image) at its own pose: a rolling shutter. `rig` is normally
// SyntheticRig(options.sensor, options.resolution_scale). Throws ConfigError for options
// failing Check().
SyntheticFrame RenderSyntheticFrame(
    const SyntheticScene& scene, const Rig& rig, const Eigen::Isometry3d& T_w_c,
    const SyntheticDatasetOptions& options, int index,
    const std::function<Eigen::Isometry3d(int row)>& T_w_c_of_row = nullptr);

// The timestamp of frame i.
double SyntheticTimestamp(const SyntheticDatasetOptions& options, int i);

// Writes the dataset into `directory` (created if missing; files already there with the
// same names are replaced). Throws ConfigError for options failing Check() or a trajectory
// that leaves the free space of the scene, DataError when a file cannot be written.
// `stop` (optional) is polled before each frame is rendered, from the rendering threads at
// once; once it returns true the dataset is closed with the frames 0..n-1 rendered so far
// (its lists, ground truth and synthetic.txt say n, and synthetic.txt's frames_per_loop
// the loop they lie on). Returns n (options.frames unless stopped).
int WriteSyntheticDataset(const std::string& directory, const SyntheticDatasetOptions& options,
                          const std::function<bool()>& stop = nullptr);

// The options as `key: value` lines, for reports and synthetic.txt.
std::string FormatSyntheticOptions(const SyntheticDatasetOptions& options);

}  // namespace ieslam
