#include "backend/ba_problem_io.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

#include <glog/logging.h>
#include <Eigen/Cholesky>

#include "core/error.h"
#include "core/file_util.h"
#include "core/input_file.h"

namespace ieslam {
namespace {

constexpr const char* kMagic = "ieslam_ba_problem";
constexpr int kVersion = 3;
// Version 2 is version 3 without the registered observations (its header has three counts).
constexpr int kOldestReadable = 2;
constexpr const char* kEnd = "end";

// Exactly representable: 17 significant digits round-trip every double.
std::string Exact(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

// The fields of one line after its record name, read as numbers.
class LineReader {
 public:
  LineReader(std::istringstream* in, std::string where) : in_(in), where_(std::move(where)) {}

  double Number(const char* what) {
    std::string token;
    if (!(*in_ >> token)) throw DataError(where_ + ": missing " + what);
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') {
      throw DataError(where_ + ": " + what + " is not a number: '" + token + "'");
    }
    if (!std::isfinite(value)) throw DataError(where_ + ": " + what + " is not finite: " + token);
    return value;
  }

  int64_t Integer(const char* what) {
    const double value = Number(what);
    if (value != std::floor(value) || std::abs(value) > 9.0e15) {
      throw DataError(where_ + ": " + what + " must be an integer, got " + Exact(value));
    }
    return static_cast<int64_t>(value);
  }

  void End() {
    std::string extra;
    if (*in_ >> extra) throw DataError(where_ + ": unexpected value '" + extra + "'");
  }

  const std::string& where() const { return where_; }

 private:
  std::istringstream* in_;
  std::string where_;
};

// The records after their name: `camera <width> <height> <fx> <fy> <cx> <cy>`.
void ReadCamera(LineReader* read, PinholeCamera* c) {
  c->width = static_cast<int>(read->Integer("width"));
  c->height = static_cast<int>(read->Integer("height"));
  c->fx = read->Number("fx");
  c->fy = read->Number("fy");
  c->cx = read->Number("cx");
  c->cy = read->Number("cy");
  std::string why;
  if (!c->Check(&why)) throw DataError(read->where() + ": " + why);
}

// `pose <frame> <timestamp> <r00 ... r22> <tx ty tz>`.
void ReadPose(LineReader* read, StoredBaProblem* stored) {
  const int frame = static_cast<int>(read->Integer("frame"));
  const double timestamp = read->Number("timestamp");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) T.linear()(r, k) = read->Number("rotation");
  }
  for (int r = 0; r < 3; ++r) T.translation()(r) = read->Number("translation");
  const Eigen::Matrix3d R = T.linear();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0) {
    throw DataError(read->where() + ": pose " + std::to_string(frame) + " has no rotation matrix");
  }
  if (!stored->problem.T_w_c.emplace(frame, T).second) {
    throw DataError(read->where() + ": pose " + std::to_string(frame) + " given twice");
  }
  stored->timestamps[frame] = timestamp;
}

// `feature <id> <x y z>`.
void ReadFeature(LineReader* read, BundleAdjustmentProblem* p) {
  const int64_t id = read->Integer("feature id");
  Eigen::Vector3d p_w;
  for (int r = 0; r < 3; ++r) p_w(r) = read->Number("feature position");
  if (!p->p_w.emplace(id, p_w).second) {
    throw DataError(read->where() + ": feature " + std::to_string(id) + " given twice");
  }
}

// `obs` or `registered <frame> <feature id> <u v d> <Q00 Q01 Q02 Q11 Q12 Q22>`, into `into`
// (the problem's observations or its registered ones). Undistorted pixels may lie a little
// outside the image; one farther out than the image's own size, or a range d <= 0, is
// no measurement the front end makes (it would decide the solve alone).
void ReadObservation(LineReader* read, const PinholeCamera& camera, BundleAdjustmentProblem* p,
                     std::vector<BundleAdjustmentObservation>* into) {
  BundleAdjustmentObservation o;
  o.frame_id = static_cast<int>(read->Integer("frame"));
  o.observation.feature_id = read->Integer("feature id");
  if (!p->T_w_c.count(o.frame_id) || !p->p_w.count(o.observation.feature_id)) {
    throw DataError(read->where() + ": observation of an unknown pose " +
                    std::to_string(o.frame_id) + " or feature " +
                    std::to_string(o.observation.feature_id) + " (poses and features come first)");
  }
  Eigen::Vector3d& z = o.observation.z;
  for (int r = 0; r < 3; ++r) z(r) = read->Number("measurement");
  if (z(0) < -camera.width || z(0) > 2.0 * camera.width || z(1) < -camera.height ||
      z(1) > 2.0 * camera.height) {
    throw DataError(read->where() + ": observation (u, v) = (" + Exact(z(0)) + ", " + Exact(z(1)) +
                    ") lies farther outside the " + std::to_string(camera.width) + "x" +
                    std::to_string(camera.height) + " image than its size");
  }
  if (z(2) <= 0.0)
    throw DataError(read->where() + ": observation range d = " + Exact(z(2)) + " <= 0");
  for (int r = 0; r < 3; ++r) {
    for (int k = r; k < 3; ++k) o.observation.Q(r, k) = o.observation.Q(k, r) = read->Number("Q");
  }
  if (o.observation.Q.llt().info() != Eigen::Success) {
    throw DataError(read->where() + ": Q is not positive definite");
  }
  into->push_back(o);
}

void WriteObservation(std::ostream& out, const char* record, const BundleAdjustmentObservation& o) {
  const FeatureObservation& obs = o.observation;
  out << record << ' ' << o.frame_id << ' ' << obs.feature_id;
  for (int r = 0; r < 3; ++r) out << ' ' << Exact(obs.z(r));
  for (int r = 0; r < 3; ++r) {
    for (int k = r; k < 3; ++k) out << ' ' << Exact(obs.Q(r, k));
  }
  out << '\n';
}

}  // namespace

void WriteBaProblem(const std::string& path, const StoredBaProblem& stored) {
  const BundleAdjustmentProblem& p = stored.problem;
  WriteFileAtomically(path, [&](std::ostream& out) {
    out << "# ieslam bundle-adjustment problem: the selected poses (T_w_c), the features and the\n"
           "# observations (u v d, undistorted) with their covariance Q that the filter used,\n"
           "# then, where its observation gate took them otherwise, all as registered.\n"
           "# Refine it with: ieslam refine --run <this run's directory> --output OUT\n";
    out << kMagic << ' ' << kVersion << ' ' << p.T_w_c.size() << ' ' << p.p_w.size() << ' '
        << p.observations.size() << ' ' << p.registered.size() << '\n';
    const PinholeCamera& c = stored.camera;
    out << "camera " << c.width << ' ' << c.height << ' ' << Exact(c.fx) << ' ' << Exact(c.fy)
        << ' ' << Exact(c.cx) << ' ' << Exact(c.cy) << '\n';
    out << "anchor " << p.AnchorFrameId() << '\n';
    for (const auto& [frame, T] : p.T_w_c) {
      const auto t = stored.timestamps.find(frame);
      CHECK(t != stored.timestamps.end()) << "no timestamp for pose " << frame;
      out << "pose " << frame << ' ' << Exact(t->second);
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) out << ' ' << Exact(T.linear()(r, k));
      }
      for (int r = 0; r < 3; ++r) out << ' ' << Exact(T.translation()(r));
      out << '\n';
    }
    for (const auto& [id, p_w] : p.p_w) {
      out << "feature " << id << ' ' << Exact(p_w.x()) << ' ' << Exact(p_w.y()) << ' '
          << Exact(p_w.z()) << '\n';
    }
    for (const BundleAdjustmentObservation& o : p.observations) WriteObservation(out, "obs", o);
    for (const BundleAdjustmentObservation& o : p.registered) {
      WriteObservation(out, "registered", o);
    }
    out << kEnd << '\n';
  });
}

StoredBaProblem ReadBaProblem(const std::string& path) {
  RequireRegularInputFile(path, "bundle-adjustment problem", kMaxBaProblemBytes);
  std::ifstream in(path);
  if (!in) throw DataError("cannot read " + path);
  StoredBaProblem stored;
  BundleAdjustmentProblem& p = stored.problem;
  bool header = false, camera = false, end = false;
  int64_t poses = 0, features = 0, observations = 0, registered = 0;  // as the header counts them
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string record;
    fields >> record;
    LineReader read(&fields, path + ":" + std::to_string(number));
    if (end) throw DataError(read.where() + ": '" + record + "' after the end line");
    if (!header) {
      if (record != kMagic)
        throw DataError(read.where() + ": not an ieslam bundle-adjustment problem");
      const int64_t version = read.Integer("version");
      if (version < kOldestReadable) {
        throw DataError(read.where() + ": format version " + std::to_string(version) +
                        ", written by an older ieslam (this one reads versions " +
                        std::to_string(kOldestReadable) + "-" + std::to_string(kVersion) +
                        "); re-run `ieslam run` to write it again");
      }
      if (version > kVersion)
        throw DataError(read.where() + ": unsupported version " + std::to_string(version));
      poses = read.Integer("pose count");
      features = read.Integer("feature count");
      observations = read.Integer("observation count");
      if (version >= 3) registered = read.Integer("registered observation count");
      header = true;
    } else if (record == "camera") {
      ReadCamera(&read, &stored.camera);
      camera = true;
    } else if (record == "anchor") {
      p.anchor_frame_id = static_cast<int>(read.Integer("anchor frame"));
    } else if (record == "pose") {
      ReadPose(&read, &stored);
    } else if (record == "feature") {
      ReadFeature(&read, &p);
    } else if (record == "obs" || record == "registered") {
      if (!camera) throw DataError(read.where() + ": observation before the camera line");
      ReadObservation(&read, stored.camera, &p, record == "obs" ? &p.observations : &p.registered);
    } else if (record == kEnd) {
      end = true;
    } else {
      throw DataError(read.where() + ": unknown record '" + record + "'");
    }
    read.End();
  }
  if (!header || !camera || p.T_w_c.empty()) {
    throw DataError(path +
                    ": incomplete bundle-adjustment problem (header, camera or poses missing)");
  }
  const auto count = [&](const char* what, size_t have, int64_t said) {
    if (static_cast<int64_t>(have) == said) return;
    throw DataError(path + ": " + std::to_string(have) + " " + what + ", the header says " +
                    std::to_string(said) + (end ? "" : " (the file is cut short)"));
  };
  count("poses", p.T_w_c.size(), poses);
  count("features", p.p_w.size(), features);
  count("observations", p.observations.size(), observations);
  count("registered observations", p.registered.size(), registered);
  if (!end) throw DataError(path + ": no end line (the file is cut short)");
  if (p.anchor_frame_id >= 0 && !p.T_w_c.count(p.anchor_frame_id)) {
    throw DataError(path + ": anchor frame " + std::to_string(p.anchor_frame_id) + " has no pose");
  }
  return stored;
}

}  // namespace ieslam
