#include "core/calibration.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <glog/logging.h>
#include <Eigen/SVD>
#include <opencv2/core.hpp>

#include "core/data_directory.h"
#include "core/error.h"
#include "core/file_util.h"
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
  int Integer(const std::string& key) const {
    const double v = Number(key);
    if (v != std::floor(v) || std::fabs(v) > 1e9) Fail(key, "must be an integer, got " + Str(v));
    return static_cast<int>(v);
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

PinholeCamera ReadIntrinsics(const Section& s) {
  PinholeCamera camera;
  camera.width = s.Integer("width");
  camera.height = s.Integer("height");
  camera.fx = s.Number("fx");
  camera.fy = s.Number("fy");
  camera.cx = s.Number("cx");
  camera.cy = s.Number("cy");
  const std::vector<double> d = s.Numbers("distortion", 5);
  std::copy(d.begin(), d.end(), camera.distortion.begin());
  return camera;
}

bool SameIntrinsics(const PinholeCamera& a, const PinholeCamera& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

RangeImager ReadRange(const Section& s, const PinholeCamera& colour, bool registered) {
  std::set<std::string> allowed = {"depth_scale", "depth_kind",  "invalid_values",
                                   "min_range_m", "max_range_m", "noise"};
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
  const Section noise = s.Map("noise");
  noise.OnlyKeys({"a", "b", "c"});
  range.noise.a = noise.Number("a");
  range.noise.b = noise.Number("b");
  range.noise.c = noise.Number("c");
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

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError("calibration file not found or unreadable: " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The rig in an opened calibration file (see ParseCalibration).
Rig RigFromYaml(const cv::FileStorage& fs, const std::string& source) {
  const Section root(fs.root(), "", &source);
  std::set<std::string> allowed = {"name",   "registered", "pixel_sigma",
                                   "colour", "range",      "T_colour_range"};
  root.OnlyKeys(allowed);

  Rig rig;
  rig.name = root.String("name");
  const int registered = root.Integer("registered");
  if (registered != 0 && registered != 1) root.Fail("registered", "must be 0 or 1");
  rig.registered = registered == 1;
  rig.pixel_sigma = root.Number("pixel_sigma");
  const Section colour = root.Map("colour");
  colour.OnlyKeys({std::begin(kIntrinsicKeys), std::end(kIntrinsicKeys)});
  rig.colour = ReadIntrinsics(colour);
  rig.range = ReadRange(root.Map("range"), rig.colour, rig.registered);
  if (!rig.registered || root.Has("T_colour_range")) {
    rig.T_colour_range = ReadExtrinsics(root);
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
