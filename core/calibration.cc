#include "core/calibration.h"

#include <cmath>
#include <set>
#include <sstream>
#include <vector>

#include <glog/logging.h>
#include <Eigen/SVD>
#include <opencv2/core.hpp>

#include "core/data_directory.h"
#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"
#include "core/yaml_text.h"

namespace ieslam {
namespace {

const char* const kIntrinsicKeys[] = {"width", "height", "fx", "fy", "cx", "cy", "distortion"};

// Typed access to one YAML map, with messages that name the source and the dotted key.
class Section {
 public:
  Section(const cv::FileNode& node, std::string prefix, const std::string* source)
      : node_(node), prefix_(std::move(prefix)), source_(source) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const {
    throw ConfigError(*source_ + ": key '" + prefix_ + key + "' " + problem);
  }
  bool Has(const std::string& key) const { return !node_[key].empty(); }
  cv::FileNode Get(const std::string& key) const {
    cv::FileNode n = node_[key];
    if (n.empty()) Fail(key, "is missing");
    return n;
  }
  Section Map(const std::string& key) const {
    cv::FileNode n = Get(key);
    if (!n.isMap()) Fail(key, "must be a map of keys");
    return Section(n, prefix_ + key + ".", source_);
  }
  double Number(const std::string& key) const { return ToNumber(Get(key), key); }
  // An integer in [min, max] (checked before it is narrowed to int).
  int Integer(const std::string& key, int min, int max) const {
    const double v = Number(key);
    if (v != std::floor(v)) Fail(key, "must be an integer, got " + Str(v));
    InRange(key, v, min, max);
    return static_cast<int>(v);
  }
  // Fails naming `key` unless min <= value <= max.
  void InRange(const std::string& key, double value, double min, double max) const {
    if (!(value >= min && value <= max)) {
      std::ostringstream range;
      range << "must be in [" << min << ", " << max << "], got ";
      range.precision(15);  // enough to tell the value, short enough to read
      range << value;
      Fail(key, range.str());
    }
  }
  std::string String(const std::string& key) const {
    cv::FileNode n = Get(key);
    if (!n.isString()) Fail(key, "must be a string");
    return n.string();
  }
  // A sequence of numbers; `size` < 0 accepts any length.
  std::vector<double> Numbers(const std::string& key, int size) const {
    cv::FileNode n = Get(key);
    if (!n.isSeq()) Fail(key, "must be a list like [1, 2, 3]");
    std::vector<double> values;
    for (cv::FileNodeIterator it = n.begin(); it != n.end(); ++it) {
      values.push_back(ToNumber(*it, key));
    }
    if (size >= 0 && static_cast<int>(values.size()) != size) {
      Fail(key,
           "must hold " + std::to_string(size) + " values, got " + std::to_string(values.size()));
    }
    return values;
  }
  // Rejects keys outside `allowed` (a misspelt optional key would otherwise be ignored).
  void OnlyKeys(const std::set<std::string>& allowed) const {
    for (cv::FileNodeIterator it = node_.begin(); it != node_.end(); ++it) {
      const std::string name = (*it).name();
      if (allowed.count(name) == 0) Fail(name, "is not a calibration key");
    }
  }

 private:
  static std::string Str(double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
  }
  double ToNumber(const cv::FileNode& n, const std::string& key) const {
    if (!n.isInt() && !n.isReal()) Fail(key, "must be a number");
    const double v = n.real();
    if (!std::isfinite(v)) Fail(key, "must be finite, got " + Str(v));
    return v;
  }

  cv::FileNode node_;
  std::string prefix_;
  const std::string* source_;
};

// Fails naming the distortion key unless the lens model maps the image one-to-one: seen
// from the principal point, the distorted position must move outwards all the way to each
// corner and edge midpoint, and undistorting that pixel must come back to it. Otherwise
// points are lifted onto wrong rays and the estimator's equations become singular.
void CheckDistortionInvertible(const Section& s, const PinholeCamera& c) {
  if (!c.HasDistortion()) return;
  for (const double u : {0.0, c.cx, static_cast<double>(c.width)}) {
    for (const double v : {0.0, c.cy, static_cast<double>(c.height)}) {
      if (u == c.cx && v == c.cy) continue;
      const Eigen::Vector2d distorted((u - c.cx) / c.fx, (v - c.cy) / c.fy);
      const Eigen::Vector2d ray = c.Undistort(distorted);
      const std::string pixel = "(" + std::to_string(static_cast<int>(u)) + ", " +
                                std::to_string(static_cast<int>(v)) + ")";
      // Undistort is exact to ~1e-12 where the model inverts; 1e-6 is ~1e-3 pixels.
      if (!ray.allFinite() || (c.Distort(ray) - distorted).norm() > 1e-6) {
        s.Fail("distortion", "does not invert at pixel " + pixel + " (no lens distorts so)");
      }
      const Eigen::Vector2d outwards = distorted.normalized();
      double previous = 0.0;
      constexpr int kSteps = 100;
      for (int i = 1; i <= kSteps; ++i) {
        const double along = c.Distort(ray * (static_cast<double>(i) / kSteps)).dot(outwards);
        if (!(along > previous)) {
          s.Fail("distortion", "folds the image over between the principal point and pixel " +
                                   pixel + " (no lens distorts so)");
        }
        previous = along;
      }
    }
  }
}

PinholeCamera ReadIntrinsics(const Section& s) {
  PinholeCamera camera;
  // No depth or colour sensor has a side over 65536 pixels.
  camera.width = s.Integer("width", 1, 65536);
  camera.height = s.Integer("height", 1, 65536);
  // A focal length of 0.05 sides is a 169 degree field of view, wider than a pinhole model
  // with this distortion can describe; 100 sides is 0.6 degrees, a telescope.
  camera.fx = s.Number("fx");
  s.InRange("fx", camera.fx, 0.05 * camera.width, 100.0 * camera.width);
  camera.fy = s.Number("fy");
  s.InRange("fy", camera.fy, 0.05 * camera.height, 100.0 * camera.height);
  // The optical axis of a real camera meets the sensor, near its centre.
  camera.cx = s.Number("cx");
  s.InRange("cx", camera.cx, 0.0, camera.width);
  camera.cy = s.Number("cy");
  s.InRange("cy", camera.cy, 0.0, camera.height);
  const std::vector<double> d = s.Numbers("distortion", 5);
  // Fitted lens coefficients are of order 1 (the TUM Kinect's reach 1.16), tangential ones
  // of order 0.01; these bounds are ten to a hundred times that.
  const double bounds[] = {100.0, 100.0, 1.0, 1.0, 100.0};
  for (int i = 0; i < 5; ++i) {
    if (!(std::fabs(d[i]) <= bounds[i])) {
      s.Fail("distortion",
             "coefficient " + std::to_string(i + 1) + " (k1, k2, p1, p2, k3) must be within +-" +
                 std::to_string(static_cast<int>(bounds[i])) + ", got " + std::to_string(d[i]));
    }
  }
  std::copy(d.begin(), d.end(), camera.distortion.begin());
  CheckDistortionInvertible(s, camera);
  return camera;
}

bool SameIntrinsics(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

RangeImager ReadRange(const Section& s, const PinholeCamera& colour, bool registered) {
  std::set<std::string> allowed = {"depth_scale", "depth_kind", "invalid_values",  "min_range_m",
                                   "max_range_m", "noise",      "depth_correction"};
  allowed.insert(std::begin(kIntrinsicKeys), std::end(kIntrinsicKeys));
  s.OnlyKeys(allowed);
  RangeImager range;
  // A registered depth image lives on the colour pixel grid, so it has no intrinsics of
  // its own; allowing them only when equal catches files that contradict themselves.
  if (!registered || s.Has("fx")) {
    range.camera = ReadIntrinsics(s);
    if (registered && !SameIntrinsics(range.camera, colour)) {
      s.Fail("fx",
             "and the other range intrinsics must equal colour's when registered: 1 "
             "(or be omitted)");
    }
  } else {
    range.camera = colour;
  }
  range.depth_scale = s.Number("depth_scale");
  // A raw unit between a micrometre and a metre: 16 bits then span 6.5 cm to 65 km.
  s.InRange("depth_scale", range.depth_scale, 1e-6, 1.0);
  const std::string kind = s.String("depth_kind");
  if (kind == "z") {
    range.depth_kind = DepthKind::kZ;
  } else if (kind == "radial") {
    range.depth_kind = DepthKind::kRadial;
  } else {
    s.Fail("depth_kind", "must be 'z' or 'radial', got '" + kind + "'");
  }
  range.invalid_values.clear();
  for (double v : s.Numbers("invalid_values", -1)) {
    if (v != std::floor(v) || v < 0.0 || v > 65535.0) {
      s.Fail("invalid_values", "must hold raw 16-bit integers (0..65535)");
    }
    range.invalid_values.push_back(static_cast<int>(v));
  }
  range.min_range_m = s.Number("min_range_m");
  range.max_range_m = s.Number("max_range_m");
  // No range imager this pipeline models measures a kilometre.
  s.InRange("max_range_m", range.max_range_m, 0.0, 1000.0);
  const Section noise = s.Map("noise");
  noise.OnlyKeys({"a", "b", "c"});
  // A sigma of a metre at a metre of range carries no information.
  range.noise.a = noise.Number("a");
  noise.InRange("a", range.noise.a, 0.0, 1.0);
  range.noise.b = noise.Number("b");
  noise.InRange("b", range.noise.b, 0.0, 1.0);
  range.noise.c = noise.Number("c");
  noise.InRange("c", range.noise.c, 0.0, 1.0);
  if (s.Has("depth_correction")) {
    const std::vector<double> k = s.Numbers("depth_correction", 3);
    for (int i = 0; i < 3; ++i) {
      // Named here with its key; RangeImager::Check holds the factor over the image too.
      if (!(std::fabs(k[i]) <= RangeImager::kMaxDepthCorrectionCoefficient)) {
        s.Fail("depth_correction", "coefficient " + std::to_string(i + 1) +
                                       " (a, b, c) must be within +-0.5, got " +
                                       std::to_string(k[i]));
      }
      range.depth_correction[i] = k[i];
    }
  }
  // No range imager measures to better than 10 micrometres, and a smaller sigma would make
  // weights (1/sigma^2) that swamp every other term of the estimator.
  if (range.min_range_m >= 0.0 && range.noise.Sigma(range.min_range_m) < 1e-5) {
    s.Fail("noise", "must give a sigma of at least 1e-05 m at min_range_m, got " +
                        std::to_string(range.noise.Sigma(range.min_range_m)));
  }
  return range;
}

Eigen::Isometry3d ReadExtrinsics(const Section& root) {
  const std::vector<double> m = root.Numbers("T_colour_range", 16);
  Eigen::Matrix4d T;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) T(r, c) = m[4 * r + c];
  }
  if ((T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) {
    root.Fail("T_colour_range", "must have a last row 0 0 0 1");
  }
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.0) {
    root.Fail("T_colour_range", "must hold a rotation (orthonormal, det +1) to 1e-6");
  }
  // Nearest rotation: files print a few decimals, and a slightly scaled "rotation" would
  // bias every point lifted from the range imager.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = svd.matrixU() * svd.matrixV().transpose();
  iso.translation() = T.topRightCorner<3, 1>();
  return iso;
}

void WriteIntrinsics(cv::FileStorage& fs, const PinholeCamera& c) {
  fs << "width" << c.width << "height" << c.height << "fx" << c.fx << "fy" << c.fy << "cx" << c.cx
     << "cy" << c.cy << "distortion"
     << "[:";
  for (double d : c.distortion) fs << d;
  fs << "]";
}

// A calibration is chosen by the user (--calib or the dataset's), so one that cannot be
// read is a configuration error (exit 2).
std::string ReadText(const std::string& path) {
  try {
    return ReadInputFile(path, "calibration file", kMaxYamlBytes);
  } catch (const DataError& e) {
    throw ConfigError(e.what());
  }
}

// The rig in an opened calibration file (see ParseCalibration).
Rig RigFromYaml(const cv::FileStorage& fs, const std::string& source) {
  const Section root(fs.root(), "", &source);
  std::set<std::string> allowed = {"name",   "registered", "pixel_sigma",
                                   "colour", "range",      "T_colour_range"};
  root.OnlyKeys(allowed);

  Rig rig;
  rig.name = root.String("name");
  rig.registered = root.Integer("registered", 0, 1) == 1;
  rig.pixel_sigma = root.Number("pixel_sigma");
  // No detector locates a keypoint to a hundredth of a pixel, and one 100 pixels off is no
  // measurement.
  root.InRange("pixel_sigma", rig.pixel_sigma, 0.01, 100.0);
  const Section colour = root.Map("colour");
  std::set<std::string> colour_keys(std::begin(kIntrinsicKeys), std::end(kIntrinsicKeys));
  colour_keys.insert("readout_s");
  colour.OnlyKeys(colour_keys);
  rig.colour = ReadIntrinsics(colour);
  if (colour.Has("readout_s")) {
    rig.colour_readout_s = colour.Number("readout_s");
    colour.InRange("readout_s", rig.colour_readout_s, -0.2, 0.2);
  }
  rig.range = ReadRange(root.Map("range"), rig.colour, rig.registered);
  if (!rig.registered || root.Has("T_colour_range")) {
    rig.T_colour_range = ReadExtrinsics(root);
    // The two sensors of a rig sit centimetres apart.
    if (!(rig.T_colour_range.translation().norm() <= 10.0)) {
      root.Fail("T_colour_range", "must move the range imager by at most 10 m, got " +
                                      std::to_string(rig.T_colour_range.translation().norm()));
    }
    if (rig.registered && !rig.T_colour_range.isApprox(Eigen::Isometry3d::Identity(), 1e-12)) {
      root.Fail("T_colour_range", "must be the identity when registered: 1 (or be omitted)");
    }
  }
  std::string why;
  if (!rig.Check(&why)) throw ConfigError(source + ": invalid calibration: " + why);
  return rig;
}

}  // namespace

Rig ParseCalibration(const std::string& yaml, const std::string& source) {
  const cv::FileStorage fs = OpenYamlMap(yaml, source);
  try {
    return RigFromYaml(fs, source);
  } catch (const cv::Exception& e) {
    throw ConfigError(source + ": not valid calibration YAML: " + e.msg);
  }
}

Rig ReadCalibration(const std::string& path) { return ParseCalibration(ReadText(path), path); }

std::string FormatCalibration(const Rig& rig) {
  std::string why;
  CHECK(rig.Check(&why)) << "writing an invalid rig '" << rig.name << "': " << why;
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "name" << rig.name << "registered" << (rig.registered ? 1 : 0) << "pixel_sigma"
     << rig.pixel_sigma;
  fs << "colour"
     << "{";
  WriteIntrinsics(fs, rig.colour);
  // Written only for a rolling shutter, so that a global-shutter rig's text stays as it was.
  if (rig.colour_readout_s != 0.0) fs << "readout_s" << rig.colour_readout_s;
  fs << "}";
  fs << "range"
     << "{";
  if (!rig.registered) WriteIntrinsics(fs, rig.range.camera);
  const RangeImager& r = rig.range;
  fs << "depth_scale" << r.depth_scale << "depth_kind"
     << (r.depth_kind == DepthKind::kZ ? "z" : "radial") << "invalid_values"
     << "[:";
  for (int v : r.invalid_values) fs << v;
  fs << "]"
     << "min_range_m" << r.min_range_m << "max_range_m" << r.max_range_m;
  fs << "noise"
     << "{:"
     << "a" << r.noise.a << "b" << r.noise.b << "c" << r.noise.c << "}";
  // Written only when there is one, so that an uncorrected rig's text stays as it was.
  if (r.HasDepthCorrection()) {
    fs << "depth_correction"
       << "[:" << r.depth_correction[0] << r.depth_correction[1] << r.depth_correction[2] << "]";
  }
  fs << "}";
  fs << "T_colour_range"
     << "[:";
  const Eigen::Matrix4d T = rig.T_colour_range.matrix();
  for (int row = 0; row < 4; ++row) {
    for (int col = 0; col < 4; ++col) fs << T(row, col);
  }
  fs << "]";
  return fs.releaseAndGetString();
}

void WriteCalibration(const std::string& path, const Rig& rig) {
  WriteTextAtomically(path, FormatCalibration(rig));
}

std::string DefaultCalibrationPath(const std::string& name) {
  return JoinPath(JoinPath(DataDirectory(), "calib"), name + ".yaml");
}

}  // namespace ieslam
