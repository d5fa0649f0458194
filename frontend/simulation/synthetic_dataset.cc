#include "frontend/simulation/synthetic_dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <glog/logging.h>
#include <opencv2/imgcodecs.hpp>

#include "core/calibration.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

// Scales intrinsics to a resolution `scale` times the original, keeping the image's
// extent: pixel centres sit at (u + 0.5) * scale - 0.5.
PinholeCamera Scaled(PinholeCamera camera, double scale) {
  camera.width = static_cast<int>(std::lround(camera.width * scale));
  camera.height = static_cast<int>(std::lround(camera.height * scale));
  camera.fx *= scale;
  camera.fy *= scale;
  camera.cx = (camera.cx + 0.5) * scale - 0.5;
  camera.cy = (camera.cy + 0.5) * scale - 0.5;
  return camera;
}

PinholeCamera Camera(int width, int height, double f) {
  PinholeCamera camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = f;
  camera.cx = 0.5 * width - 0.5;
  camera.cy = 0.5 * height - 0.5;
  return camera;
}

std::string StampString(double t) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), "%.6f", t);
  return buffer;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image, bytes)) throw DataError("cannot encode PNG " + path);
  WriteFileAtomically(
      path,
      [&bytes](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(bytes.data()),
                  static_cast<std::streamsize>(bytes.size()));
      },
      /*binary=*/true);
}

void MakeDirectory(const std::string& path) {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path)) {
    throw DataError("cannot create directory " + path + (ec ? ": " + ec.message() : ""));
  }
}

RenderOptions MakeRenderOptions(const SyntheticDatasetOptions& options, bool colour) {
  RenderOptions render;
  render.threads = options.threads;
  render.edge_supersampling = options.edge_supersampling;
  render.colour = colour;
  return render;
}

}  // namespace

const char* ToString(SyntheticSensor sensor) {
  return sensor == SyntheticSensor::kRgbd ? "rgbd" : "pair";
}

SyntheticSensor ParseSyntheticSensor(const std::string& name) {
  if (name == "rgbd") return SyntheticSensor::kRgbd;
  if (name == "pair") return SyntheticSensor::kPair;
  throw ConfigError("synthetic sensor must be rgbd or pair, got '" + name + "'");
}

bool SyntheticDatasetOptions::Check(std::string* why) const {
  std::ostringstream s;
  std::string part;
  const Rig rig = SyntheticRig(sensor, 1.0);
  const int smallest = std::min(rig.range.camera.width, rig.range.camera.height);
  if (frames_per_loop < 0) {
    s << "frames_per_loop must be >= 0, got " << frames_per_loop;
    if (why != nullptr) *why = s.str();
    return false;
  }
  if (frames < 1 || frames > 1000000) {
    s << "frames must be in [1, 1000000], got " << frames;
  } else if (!(frame_rate_hz > 0.0) || !(frame_rate_hz <= 1000.0)) {
    s << "frame_rate_hz must be in (0, 1000], got " << frame_rate_hz;
  } else if (!(start_time_s >= 0.0) || !(start_time_s < 1e9)) {
    s << "start_time_s must be in [0, 1e9), got " << start_time_s;
  } else if (!(resolution_scale > 0.0) || !(resolution_scale <= 4.0) ||
             smallest * resolution_scale < 16.0) {
    s << "resolution_scale must be in (0, 4] and leave images at least 16 pixels wide, got "
      << resolution_scale;
  } else if (!(std::fabs(readout_s) <= 0.2) || !(std::fabs(readout_s) * frame_rate_hz <= 1.0)) {
    s << "readout_s must be within +-0.2 s and one frame period, got " << readout_s;
  } else if (readout_s != 0.0 && sensor != SyntheticSensor::kRgbd) {
    s << "readout_s (a rolling shutter) is rendered for the rgbd sensor only";
  } else if (!std::all_of(depth_correction.begin(), depth_correction.end(),
                          [](double k) { return std::fabs(k) <= 0.5; })) {
    s << "depth_correction coefficients must be within +-0.5, got [" << depth_correction[0] << ", "
      << depth_correction[1] << ", " << depth_correction[2] << "]";
  } else if (!(colour_noise_sigma >= 0.0) || !(colour_noise_sigma <= 50.0)) {
    s << "colour_noise_sigma must be in [0, 50] grey levels, got " << colour_noise_sigma;
  } else if (!RangeSensorModel{max_incidence_deg, add_noise}.Check(&part) ||
             !MakeRenderOptions(*this, true).Check(&part) || !scene.Check(&part) ||
             !trajectory.Check(&part)) {
    s << part;
  } else {
    return true;
  }
  if (why != nullptr) *why = s.str();
  return false;
}

Rig SyntheticRig(SyntheticSensor sensor, double resolution_scale) {
  CHECK(resolution_scale > 0.0);
  Rig rig;
  if (sensor == SyntheticSensor::kRgbd) {
    rig.name = "synthetic_rgbd";
    rig.registered = true;
    rig.colour = Scaled(Camera(640, 480, 525.0), resolution_scale);
    rig.range.camera = rig.colour;
    rig.range.depth_scale = 1.0 / 5000.0;
    rig.range.depth_kind = DepthKind::kZ;
    rig.range.min_range_m = 0.4;
    rig.range.max_range_m = 4.5;
    rig.range.noise = {0.0002, 0.0, 0.0016};
  } else {
    rig.name = "synthetic_pair";
    rig.registered = false;
    rig.colour = Scaled(Camera(1024, 768, 800.0), resolution_scale);
    rig.range.camera = Scaled(Camera(176, 144, 225.0), resolution_scale);
    rig.range.depth_scale = 0.001;
    rig.range.depth_kind = DepthKind::kRadial;
    rig.range.min_range_m = 0.3;
    rig.range.max_range_m = 7.5;
    rig.range.noise = {0.005, 0.01, 0.0};
    rig.T_colour_range.linear() =
        (Eigen::AngleAxisd(0.4 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(-0.6 * M_PI / 180.0, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(0.3 * M_PI / 180.0, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    rig.T_colour_range.translation() = Eigen::Vector3d(0.05, 0.0, 0.0);
  }
  rig.range.invalid_values = {0};
  rig.pixel_sigma = 1.0;
  std::string why;
  CHECK(rig.Check(&why)) << why;
  return rig;
}

double SyntheticTimestamp(const SyntheticDatasetOptions& options, int i) {
  return options.start_time_s + i / options.frame_rate_hz;
}

SyntheticFrame RenderSyntheticFrame(const SyntheticScene& scene, const Rig& rig,
                                    const Eigen::Isometry3d& T_w_c,
                                    const SyntheticDatasetOptions& options, int index,
                                    const std::function<Eigen::Isometry3d(int row)>& T_w_c_of_row) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("synthetic dataset options: " + why);
  SyntheticFrame frame;
  frame.timestamp = SyntheticTimestamp(options, index);
  frame.T_w_c = T_w_c;
  frame.colour_view =
      T_w_c_of_row ? RenderView(scene, rig.colour, T_w_c_of_row, MakeRenderOptions(options, true))
                   : RenderView(scene, rig.colour, T_w_c, MakeRenderOptions(options, true));
  if (rig.registered) {
    frame.range_view = frame.colour_view;
  } else {
    frame.range_view = RenderView(scene, rig.range.camera, T_w_c * rig.T_colour_range,
                                  MakeRenderOptions(options, false));
  }
  std::seed_seq seed{options.noise_seed, static_cast<uint32_t>(index)};
  std::mt19937 rng(seed);
  frame.colour = AddColourNoise(frame.colour_view.colour,
                                options.add_noise ? options.colour_noise_sigma : 0.0, &rng);
  frame.range_raw = SimulateRangeImage(frame.range_view, rig.range,
                                       {options.max_incidence_deg, options.add_noise}, &rng);
  return frame;
}

namespace {

// Where a dataset's files go: the rgbd (TUM) or the pair layout.
struct DatasetLayout {
  std::string directory;
  bool rgbd = true;
  std::string colour_dir;
  std::string range_dir;

  DatasetLayout(const std::string& dir, SyntheticSensor sensor)
      : directory(dir),
        rgbd(sensor == SyntheticSensor::kRgbd),
        colour_dir(rgbd ? "rgb" : "colour"),
        range_dir(rgbd ? "depth" : "range") {}

  // Frame i's colour and range images.
  std::pair<std::string, std::string> ImagePaths(const SyntheticDatasetOptions& options,
                                                 int i) const {
    const std::string stamp = StampString(SyntheticTimestamp(options, i));
    return std::make_pair(JoinPath(directory, colour_dir + "/" + stamp + ".png"),
                          JoinPath(directory, range_dir + "/" + stamp + ".png"));
  }
};

// Throws ConfigError when a camera of the first `frames` poses is not in the free space.
void RequireFreeSpace(const SyntheticScene& scene, const Rig& rig,
                      const std::vector<Eigen::Isometry3d>& poses, int frames) {
  for (int i = 0; i < frames; ++i) {
    const Eigen::Vector3d p = poses[i].translation();
    const Eigen::Vector3d p_range = (poses[i] * rig.T_colour_range).translation();
    if (!scene.IsFreeSpace(p, 0.3) || !scene.IsFreeSpace(p_range, 0.3)) {
      std::ostringstream s;
      s << "synthetic dataset: frame " << i << ": the camera at (" << p.transpose()
        << ") is within 0.3 m of a box or outside the room; shrink trajectory.radii_m or "
           "enlarge scene.clear_radii_m";
      throw ConfigError(s.str());
    }
  }
}

// Renders and writes the images of every frame until `stop`; returns which were written.
// Frames are independent (each seeds its own noise), so whole frames go to the threads:
// rendering, noise and PNG encoding all run in parallel, and the files are the same for
// any thread count.
std::vector<char> WriteImages(const DatasetLayout& layout, const SyntheticScene& scene,
                              const Rig& rig, const std::vector<Eigen::Isometry3d>& poses,
                              const SyntheticDatasetOptions& options,
                              const std::function<bool()>& stop) {
  SyntheticDatasetOptions single_thread = options;
  single_thread.threads = 1;
  const int workers = std::min(
      options.frames, options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency())));
  std::vector<std::exception_ptr> errors(workers);
  std::vector<char> written(options.frames, 0);  // each entry set by one worker only
  auto work = [&](int k) {
    try {
      for (int i = k; i < options.frames && !(stop && stop()); i += workers) {
        std::function<Eigen::Isometry3d(int)> rows;
        if (rig.colour_readout_s != 0.0) {
          rows = [&, i](int row) {
            return SyntheticTrajectoryPose(options.trajectory,
                                           i + rig.RowTimeOffset(row) * options.frame_rate_hz,
                                           static_cast<int>(poses.size()));
          };
        }
        const SyntheticFrame frame =
            RenderSyntheticFrame(scene, rig, poses[i], single_thread, i, rows);
        const auto [colour_path, range_path] = layout.ImagePaths(options, i);
        WritePng(colour_path, frame.colour);
        WritePng(range_path, frame.range_raw);
        written[i] = 1;
      }
    } catch (...) {
      errors[k] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  for (int k = 1; k < workers; ++k) threads.emplace_back(work, k);
  work(0);
  for (std::thread& thread : threads) thread.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
  return written;
}

// Removes the images of frames from `first` on that a worker wrote before it stopped: no
// image is left unlisted.
void RemoveImagesFrom(int first, const std::vector<char>& written, const DatasetLayout& layout,
                      const SyntheticDatasetOptions& options) {
  for (int i = first; i < static_cast<int>(written.size()); ++i) {
    if (!written[i]) continue;
    const auto [colour_path, range_path] = layout.ImagePaths(options, i);
    for (const std::string& path : {colour_path, range_path}) {
      std::error_code error;
      std::filesystem::remove(path, error);
      if (error) {
        throw DataError("cannot remove " + path +
                        " (not part of the stopped dataset): " + error.message());
      }
    }
  }
}

// The lists, ground truth, calibration and synthetic.txt of the frames of `as_written`,
// the lists last.
void WriteListsAndMetadata(const DatasetLayout& layout, const Rig& rig,
                           const std::vector<Eigen::Isometry3d>& poses,
                           const SyntheticDatasetOptions& options,
                           const SyntheticDatasetOptions& as_written) {
  std::ostringstream colour_list, range_list;
  if (layout.rgbd) {
    colour_list << "# color images\n# file: 'ieslam synthetic rgbd'\n# timestamp filename\n";
    range_list << "# depth maps\n# file: 'ieslam synthetic rgbd'\n# timestamp filename\n";
  } else {
    colour_list << "# colour images\n# file: 'ieslam synthetic pair'\n# timestamp filename\n";
    range_list << "# range images (radial, 16-bit mm)\n# file: 'ieslam synthetic pair'\n"
                  "# timestamp filename\n";
  }
  Trajectory ground_truth;
  for (int i = 0; i < as_written.frames; ++i) {
    const double t = SyntheticTimestamp(options, i);
    const std::string stamp = StampString(t);
    colour_list << stamp << " " << layout.colour_dir << "/" << stamp << ".png\n";
    range_list << stamp << " " << layout.range_dir << "/" << stamp << ".png\n";
    ground_truth.push_back({t, poses[i]});
  }
  const std::string& directory = layout.directory;
  WriteCalibration(JoinPath(directory, "calib.yaml"), rig);
  WriteTumTrajectory(JoinPath(directory, "groundtruth.txt"), ground_truth,
                     " ground truth (exact) of the colour camera, T_w_c: ieslam synthetic " +
                         std::string(ToString(options.sensor)));
  WriteTextAtomically(JoinPath(directory, "synthetic.txt"), FormatSyntheticOptions(as_written));
  WriteTextAtomically(JoinPath(directory, layout.rgbd ? "rgb.txt" : "colour.txt"),
                      colour_list.str());
  WriteTextAtomically(JoinPath(directory, layout.rgbd ? "depth.txt" : "range.txt"),
                      range_list.str());
}

}  // namespace

int WriteSyntheticDataset(const std::string& directory, const SyntheticDatasetOptions& options,
                          const std::function<bool()>& stop) {
  std::string why;
  if (!options.Check(&why)) throw ConfigError("synthetic dataset options: " + why);
  const SyntheticScene scene(options.scene);
  Rig rig = SyntheticRig(options.sensor, options.resolution_scale);
  rig.colour_readout_s = options.readout_s;
  rig.range.depth_correction = options.depth_correction;
  if (!rig.Check(&why)) throw ConfigError("synthetic dataset options: " + why);
  const std::vector<Eigen::Isometry3d> poses = BuildSyntheticTrajectory(
      options.trajectory, std::max(options.frames, options.frames_per_loop));
  RequireFreeSpace(scene, rig, poses, options.frames);

  const DatasetLayout layout(directory, options.sensor);
  MakeDirectory(directory);
  MakeDirectory(JoinPath(directory, layout.colour_dir));
  MakeDirectory(JoinPath(directory, layout.range_dir));
  const std::vector<char> written = WriteImages(layout, scene, rig, poses, options, stop);

  // Stopped, the dataset ends before the first frame a worker did not write. Its poses are
  // still those of the loop `options` asked for, which synthetic.txt must then say.
  SyntheticDatasetOptions as_written = options;
  as_written.frames =
      static_cast<int>(std::find(written.begin(), written.end(), 0) - written.begin());
  if (as_written.frames < options.frames) {
    as_written.frames_per_loop = std::max(options.frames, options.frames_per_loop);
  }
  RemoveImagesFrom(as_written.frames, written, layout, options);
  WriteListsAndMetadata(layout, rig, poses, options, as_written);
  return as_written.frames;
}

namespace {

// A global shutter's line is left out, so that such a dataset's synthetic.txt stays as it was.
std::string ReadoutLine(double readout_s) {
  if (readout_s == 0.0) return "";
  std::ostringstream s;
  s.precision(17);
  s << "\nreadout_s: " << readout_s;
  return s.str();
}

// Likewise the line of a depth correction.
std::string DepthCorrectionLine(const std::array<double, 3>& k) {
  if (k[0] == 0.0 && k[1] == 0.0 && k[2] == 0.0) return "";
  std::ostringstream s;
  s.precision(17);
  s << "\ndepth_correction: [" << k[0] << ", " << k[1] << ", " << k[2] << "]";
  return s.str();
}

}  // namespace

std::string FormatSyntheticOptions(const SyntheticDatasetOptions& o) {
  std::ostringstream s;
  s.precision(17);
  const SyntheticTrajectoryOptions& t = o.trajectory;
  s << "sensor: " << ToString(o.sensor) << "\nframes: " << o.frames
    << "\nframes_per_loop: " << o.frames_per_loop << "\nframe_rate_hz: " << o.frame_rate_hz
    << "\nstart_time_s: " << o.start_time_s << "\nresolution_scale: " << o.resolution_scale
    << "\nadd_noise: " << o.add_noise << "\ncolour_noise_sigma: " << o.colour_noise_sigma
    << "\nmax_incidence_deg: " << o.max_incidence_deg
    << "\nedge_supersampling: " << o.edge_supersampling << "\nnoise_seed: " << o.noise_seed
    << ReadoutLine(o.readout_s) << DepthCorrectionLine(o.depth_correction)
    << "\nscene.seed: " << o.scene.seed << "\nscene.room_size_m: ["
    << o.scene.room_size_m.transpose() << "]\nscene.box_count: " << o.scene.box_count
    << "\nscene.board_count: " << o.scene.board_count << "\nscene.clear_radii_m: ["
    << o.scene.clear_radii_m.transpose() << "]\ntrajectory.centre_m: [" << t.centre_m.transpose()
    << "]\ntrajectory.radii_m: [" << t.radii_m.transpose()
    << "]\ntrajectory.height_m: " << t.height_m
    << "\ntrajectory.look_offset_deg: " << t.look_offset_deg
    << "\ntrajectory.pitch_deg: " << t.pitch_deg << "\ntrajectory.radial_sway: " << t.radial_sway_m
    << " m x " << t.radial_sway_cycles << "\ntrajectory.height_bob: " << t.height_bob_m << " m x "
    << t.height_bob_cycles << "\ntrajectory.yaw_wobble: " << t.yaw_wobble_deg << " deg x "
    << t.yaw_wobble_cycles << "\ntrajectory.pitch_wobble: " << t.pitch_wobble_deg << " deg x "
    << t.pitch_wobble_cycles << "\ntrajectory.roll_wobble: " << t.roll_wobble_deg << " deg x "
    << t.roll_wobble_cycles << "\n";
  return s.str();
}

}  // namespace ieslam
