#include "core/calibration.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <unistd.h>

#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test, removed afterwards.
class CalibrationFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("ieslam_calibration_test_" + std::to_string(::getpid()) + "_" + test->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  // The ConfigError that reading `path` raises; a test failure and "" when it raises none.
  static std::string ConfigErrorOf(const std::string& path) {
    try {
      ReadCalibration(path);
    } catch (const ConfigError& e) {
      return e.what();
    }
    ADD_FAILURE() << "no ConfigError for " << path;
    return "";
  }

  fs::path dir_;
};

// A valid two-camera file; tests replace one line of it to break it.
const char kTwoCameras[] = R"(# a comment before the keys
name: test_rig
registered: 0
pixel_sigma: 0.8
colour:
  width: 1024
  height: 768
  fx: 1290.0
  fy: 1291.5
  cx: 511.5
  cy: 383.5
  distortion: [-0.2, 0.12, 0.001, -0.002, 0.01]
range:
  width: 176
  height: 144
  fx: 200.0
  fy: 201.0
  cx: 87.5
  cy: 71.5
  distortion: [0, 0, 0, 0, 0]
  depth_scale: 0.001
  depth_kind: radial
  invalid_values: [0, 65535]
  min_range_m: 0.3
  max_range_m: 7.5
  noise: {a: 0.005, b: 0.01, c: 0.0}
T_colour_range: [1, 0, 0, 0.01,  0, 1, 0, -0.045,  0, 0, 1, -0.005,  0, 0, 0, 1]
)";

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

Rig SampleRig() {
  Rig rig;
  rig.name = "7scenes_like";  // starts with a digit: the writer must quote it
  rig.colour = {800, 600, 612.25, 610.125, 401.3, 298.7, {0.1, -0.25, 1e-3, -2e-3, 0.05}};
  rig.range.camera = {176, 144, 201.0 / 3.0 * 3.0, 199.9, 88.1, 71.9, {-0.01, 0, 0, 0, 0}};
  rig.range.depth_scale = 7.5 / 65535.0;
  rig.range.depth_kind = DepthKind::kRadial;
  rig.range.invalid_values = {0, 65535, 12};
  rig.range.min_range_m = 0.25;
  rig.range.max_range_m = 7.5;
  rig.range.noise = {0.004, 0.0125, 1.0 / 3000.0};
  rig.T_colour_range = Eigen::Translation3d(0.013, -0.047, 0.002) *
                       Eigen::AngleAxisd(0.03, Eigen::Vector3d(1.0, -2.0, 0.5).normalized());
  rig.registered = false;
  rig.pixel_sigma = 0.7;
  return rig;
}

void ExpectSameCamera(const PinholeCamera& a, const PinholeCamera& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.fx, b.fx);
  EXPECT_EQ(a.fy, b.fy);
  EXPECT_EQ(a.cx, b.cx);
  EXPECT_EQ(a.cy, b.cy);
  EXPECT_EQ(a.distortion, b.distortion);
}

TEST_F(CalibrationFileTest, WriteThenReadGivesTheSameRig) {
  const Rig rig = SampleRig();
  const std::string path = (dir_ / "rig.yaml").string();
  WriteCalibration(path, rig);
  const Rig back = ReadCalibration(path);
  EXPECT_EQ(back.name, rig.name);
  ExpectSameCamera(back.colour, rig.colour);
  ExpectSameCamera(back.range.camera, rig.range.camera);
  EXPECT_EQ(back.range.depth_scale, rig.range.depth_scale);
  EXPECT_EQ(back.range.depth_kind, DepthKind::kRadial);
  EXPECT_EQ(back.range.invalid_values, rig.range.invalid_values);
  EXPECT_EQ(back.range.min_range_m, rig.range.min_range_m);
  EXPECT_EQ(back.range.max_range_m, rig.range.max_range_m);
  EXPECT_EQ(back.range.noise.a, rig.range.noise.a);
  EXPECT_EQ(back.range.noise.b, rig.range.noise.b);
  EXPECT_EQ(back.range.noise.c, rig.range.noise.c);
  EXPECT_FALSE(back.registered);
  EXPECT_EQ(back.pixel_sigma, rig.pixel_sigma);
  EXPECT_TRUE(back.T_colour_range.matrix().isApprox(rig.T_colour_range.matrix(), 1e-14))
      << back.T_colour_range.matrix();
  // No temporary file of the atomic write is left behind.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(CalibrationFileTest, RegisteredRigOmitsRangeIntrinsicsAndRoundTrips) {
  Rig rig = SampleRig();
  rig.registered = true;
  rig.range.camera = rig.colour;
  rig.range.depth_kind = DepthKind::kZ;
  rig.range.invalid_values.clear();
  rig.T_colour_range = Eigen::Isometry3d::Identity();
  const std::string text = FormatCalibration(rig);
  const Rig back = ParseCalibration(text, "memory");
  EXPECT_TRUE(back.registered);
  ExpectSameCamera(back.range.camera, rig.colour);
  EXPECT_TRUE(back.range.invalid_values.empty());
  EXPECT_EQ(back.range.depth_kind, DepthKind::kZ);
  // The range section holds no intrinsics of its own: exactly one "fx" in the text.
  EXPECT_EQ(text.find("fx"), text.rfind("fx")) << text;
}

// A rolling shutter's readout time is optional: a global shutter's file has no such key and
// its text stays as it was; a rolling shutter's reads back to the bit.
TEST_F(CalibrationFileTest, RollingShutterReadoutIsOptionalAndRoundTrips) {
  Rig rig = SampleRig();
  EXPECT_EQ(FormatCalibration(rig).find("readout_s"), std::string::npos);
  EXPECT_EQ(ParseCalibration(FormatCalibration(rig), "memory").colour_readout_s, 0.0);
  rig.colour_readout_s = -0.0312;  // read bottom to top
  const Rig back = ParseCalibration(FormatCalibration(rig), "memory");
  EXPECT_EQ(back.colour_readout_s, rig.colour_readout_s);
  EXPECT_NE(FormatCalibration(rig), FormatCalibration(SampleRig()));
}

// A depth correction is optional too: without one the text stays as it was; with one it
// reads back to the bit. A correction that doubles or halves a reading somewhere in the
// image, or a coefficient beyond +-0.5, is a ConfigError naming it.
TEST_F(CalibrationFileTest, DepthCorrectionIsOptionalRoundTripsAndIsChecked) {
  Rig rig = SampleRig();
  EXPECT_EQ(FormatCalibration(rig).find("depth_correction"), std::string::npos);
  EXPECT_FALSE(ParseCalibration(FormatCalibration(rig), "memory").range.HasDepthCorrection());
  rig.range.depth_correction = {-0.0226, 0.00296, 0.00452};
  const Rig back = ParseCalibration(FormatCalibration(rig), "memory");
  EXPECT_EQ(back.range.depth_correction, rig.range.depth_correction);
  EXPECT_DOUBLE_EQ(back.range.DepthCorrectionFactor(0.5, -0.25),
                   1.0 - 0.0226 * 0.5 - 0.00296 * 0.25 + 0.00452 * (0.25 + 0.0625));

  const std::string text = FormatCalibration(rig);
  const size_t at = text.find("depth_correction");
  ASSERT_NE(at, std::string::npos);
  const size_t end = text.find(']', at);
  const auto with = [&](const std::string& list) {
    return Write("bad.yaml",
                 text.substr(0, at) + "depth_correction: " + list + text.substr(end + 1));
  };
  for (const char* list : {"[0.6, 0.0, 0.0]", "[0.0, 0.0]"}) {
    const std::string message = ConfigErrorOf(with(list));
    EXPECT_NE(message.find("depth_correction"), std::string::npos) << list << ": " << message;
  }
  EXPECT_TRUE(ReadCalibration(with("[0.05, -0.05, 0.1]")).range.HasDepthCorrection());
  // Within the bounds, but at fr1's wide corners 1 - 0.5 (x + y + x^2 + y^2) is about 0.1.
  Rig wide = ReadCalibration(DefaultCalibrationPath("tum_fr1"));
  wide.range.depth_correction = {-0.5, -0.5, -0.5};
  std::string why;
  EXPECT_FALSE(wide.Check(&why));
  EXPECT_NE(why.find("depth_correction"), std::string::npos) << why;
}

TEST_F(CalibrationFileTest, ReadsAHandWrittenFileWithoutYamlDirective) {
  const Rig rig = ReadCalibration(Write("two.yaml", kTwoCameras));
  EXPECT_EQ(rig.name, "test_rig");
  EXPECT_EQ(rig.colour.width, 1024);
  EXPECT_DOUBLE_EQ(rig.colour.fy, 1291.5);
  EXPECT_DOUBLE_EQ(rig.colour.distortion[4], 0.01);
  EXPECT_EQ(rig.range.camera.width, 176);
  EXPECT_DOUBLE_EQ(rig.range.camera.fy, 201.0);
  EXPECT_EQ(rig.range.invalid_values, (std::vector<int>{0, 65535}));
  EXPECT_EQ(rig.range.depth_kind, DepthKind::kRadial);
  EXPECT_DOUBLE_EQ(rig.pixel_sigma, 0.8);
  EXPECT_TRUE(rig.T_colour_range.translation().isApprox(Eigen::Vector3d(0.01, -0.045, -0.005)));
}

// Each broken variant of kTwoCameras raises ConfigError naming the file and the key.
struct BadCase {
  const char* from;
  const char* to;
  const char* key_in_message;
};

TEST_F(CalibrationFileTest, BadValuesRaiseConfigErrorNamingFileAndKey) {
  const BadCase cases[] = {
      {"fx: 1290.0", "fx: .nan", "colour.fx"},
      {"fx: 1290.0", "fx: .inf", "colour.fx"},
      {"  fx: 1290.0\n", "", "colour.fx"},                   // missing key
      {"  width: 1024", "  width: wide", "colour.width"},    // wrong type
      {"  width: 1024", "  width: 1024.5", "colour.width"},  // not an integer
      {"depth_kind: radial", "depth_kind: sideways", "range.depth_kind"},
      {"distortion: [0, 0, 0, 0, 0]", "distortion: [0, 0, 0]", "range.distortion"},
      {"noise: {a: 0.005,", "noise: {aa: 0.005,", "range.noise.aa"},  // unknown key
      {"registered: 0", "registered: 2", "registered"},
      {"T_colour_range: [1, 0, 0, 0.01,", "T_colour_range: [2, 0, 0, 0.01,", "T_colour_range"},
      {"name: test_rig\n", "", "name"},
  };
  for (const BadCase& c : cases) {
    const std::string path = Write("bad.yaml", Replace(kTwoCameras, c.from, c.to));
    const std::string message = ConfigErrorOf(path);
    EXPECT_NE(message.find(path), std::string::npos) << c.to << ": " << message;
    EXPECT_NE(message.find("'" + std::string(c.key_in_message) + "'"), std::string::npos)
        << c.to << ": " << message;
  }
}

TEST_F(CalibrationFileTest, ValuesRigCheckRejectsRaiseConfigError) {
  const std::string path =
      Write("bad.yaml", Replace(kTwoCameras, "depth_scale: 0.001", "depth_scale: -0.001"));
  try {
    ReadCalibration(path);
    FAIL() << "negative depth_scale accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("depth_scale"), std::string::npos) << e.what();
  }
}

// Values that read as numbers but describe no camera (fx 1e300, a lens that folds the image
// over) used to pass and end far downstream as a singular information matrix naming
// neither the file nor the key.
TEST_F(CalibrationFileTest, PhysicallyImpossibleValuesRaiseConfigErrorNamingFileAndKey) {
  const char kColourDistortion[] = "distortion: [-0.2, 0.12, 0.001, -0.002, 0.01]";
  const BadCase cases[] = {
      {"fx: 1290.0", "fx: 1e300", "colour.fx"},
      {"fx: 1290.0", "fx: 10.0", "colour.fx"},
      {"fy: 201.0", "fy: 1e9", "range.fy"},
      {"  cx: 511.5", "  cx: -5", "colour.cx"},
      {"  cy: 71.5", "  cy: 145", "range.cy"},
      {"  height: 768", "  height: 3000000000", "colour.height"},
      {kColourDistortion, "distortion: [-0.2, 0.12, 0.001, -0.002, 1e6]", "colour.distortion"},
      {kColourDistortion, "distortion: [0, 0, 5, 0, 0]", "colour.distortion"},
      {kColourDistortion, "distortion: [-5, 0, 0, 0, 0]", "colour.distortion"},   // folds over
      {kColourDistortion, "distortion: [0, 0, 0, 0, -60]", "colour.distortion"},  // folds over
      {"depth_scale: 0.001", "depth_scale: 1e300", "range.depth_scale"},
      {"max_range_m: 7.5", "max_range_m: 1e9", "range.max_range_m"},
      {"noise: {a: 0.005, b: 0.01,", "noise: {a: 1e-300, b: 0.0,", "range.noise"},
      {"noise: {a: 0.005,", "noise: {a: 1e300,", "range.noise.a"},
      {"pixel_sigma: 0.8", "pixel_sigma: 1e-300", "pixel_sigma"},
      {"0, 1, 0, -0.045", "0, 1, 0, -4500", "T_colour_range"},
      {kColourDistortion, "distortion: [-0.2, 0.12, 0.001, -0.002, 0.01]\n  readout_s: 0.5",
       "colour.readout_s"},  // longer than a 5 Hz camera's frame
      {kColourDistortion, "distortion: [-0.2, 0.12, 0.001, -0.002, 0.01]\n  readout_s: fast",
       "colour.readout_s"},
  };
  for (const BadCase& c : cases) {
    const std::string path = Write("bad.yaml", Replace(kTwoCameras, c.from, c.to));
    const std::string message = ConfigErrorOf(path);
    EXPECT_NE(message.find(path + ": key '" + c.key_in_message + "'"), std::string::npos)
        << c.to << ": " << message;
  }
  try {
    ReadCalibration(Write("fx.yaml", Replace(kTwoCameras, "fx: 1290.0", "fx: 1e300")));
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'colour.fx' must be in [51.2, 102400], got 1e+300"),
              std::string::npos)
        << e.what();
  }
  // OpenCV alone would read 3000000000 as -1294967296.
  try {
    ReadCalibration(Write("w.yaml", Replace(kTwoCameras, "  width: 1024", "  width: 3000000000")));
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(
        std::string(e.what()).find("key 'colour.width' must be in [1, 65536], got 3000000000"),
        std::string::npos)
        << e.what();
  }
}

TEST_F(CalibrationFileTest, MissingOrUnparsableFileRaisesConfigError) {
  const std::string missing = (dir_ / "nope.yaml").string();
  EXPECT_THROW(
      {
        try {
          ReadCalibration(missing);
        } catch (const ConfigError& e) {
          EXPECT_NE(std::string(e.what()).find(missing), std::string::npos);
          throw;
        }
      },
      ConfigError);
  const std::string garbage = Write("garbage.yaml", "name: [unclosed\n  fx:: 1\n");
  EXPECT_THROW(ReadCalibration(garbage), ConfigError);
}

TEST(ShippedCalibration, TumFilesHoldTheirPublishedIntrinsics) {
  struct Expected {
    const char* name;
    double fx, fy, cx, cy, k1, k3;
  };
  const Expected expected[] = {{"tum_fr1", 517.3, 516.5, 318.6, 255.3, 0.2624, 1.1633},
                               {"tum_fr2", 520.9, 521.0, 325.1, 249.7, 0.2312, 0.9172},
                               {"tum_fr3", 535.4, 539.2, 320.1, 247.6, 0.0, 0.0}};
  for (const Expected& e : expected) {
    SCOPED_TRACE(e.name);
    const Rig rig = ReadCalibration(DefaultCalibrationPath(e.name));
    std::string why;
    EXPECT_TRUE(rig.Check(&why)) << why;
    EXPECT_EQ(rig.name, e.name);
    EXPECT_TRUE(rig.registered);
    EXPECT_EQ(rig.colour.width, 640);
    EXPECT_EQ(rig.colour.height, 480);
    EXPECT_DOUBLE_EQ(rig.colour.fx, e.fx);
    EXPECT_DOUBLE_EQ(rig.colour.fy, e.fy);
    EXPECT_DOUBLE_EQ(rig.colour.cx, e.cx);
    EXPECT_DOUBLE_EQ(rig.colour.cy, e.cy);
    EXPECT_DOUBLE_EQ(rig.colour.distortion[0], e.k1);
    EXPECT_DOUBLE_EQ(rig.colour.distortion[4], e.k3);
    ExpectSameCamera(rig.range.camera, rig.colour);
    EXPECT_DOUBLE_EQ(rig.range.depth_scale, 1.0 / 5000.0);
    EXPECT_EQ(rig.range.depth_kind, DepthKind::kZ);
    EXPECT_EQ(rig.range.invalid_values, std::vector<int>{0});
    EXPECT_TRUE(rig.T_colour_range.isApprox(Eigen::Isometry3d::Identity()));
    // Kinect noise: ~2 mm at 1 m, ~4 cm at 5 m (Khoshelham & Elberink 2012).
    EXPECT_NEAR(rig.range.noise.Sigma(1.0), 0.0018, 0.0005);
    EXPECT_NEAR(rig.range.noise.Sigma(5.0), 0.04, 0.005);
    EXPECT_DOUBLE_EQ(rig.pixel_sigma, 1.0);
  }
  EXPECT_FALSE(ReadCalibration(DefaultCalibrationPath("tum_fr3")).colour.HasDistortion());
}

TEST(ShippedCalibration, SevenScenesHasTwoCameras) {
  const Rig rig = ReadCalibration(DefaultCalibrationPath("7scenes"));
  std::string why;
  EXPECT_TRUE(rig.Check(&why)) << why;
  EXPECT_FALSE(rig.registered);
  EXPECT_DOUBLE_EQ(rig.colour.fx, 525.0);
  EXPECT_DOUBLE_EQ(rig.colour.fy, 525.0);
  EXPECT_DOUBLE_EQ(rig.range.camera.fx, 585.0);
  EXPECT_DOUBLE_EQ(rig.range.camera.fy, 585.0);
  // The colour lens's barrel distortion (measured by self-calibration, see the file).
  EXPECT_DOUBLE_EQ(rig.colour.distortion[0], -0.04);
  EXPECT_EQ(rig.range.camera.distortion, (std::array<double, 5>{0.0, 0.0, 0.0, 0.0, 0.0}));
  for (const PinholeCamera* c : {&rig.colour, &rig.range.camera}) {
    EXPECT_EQ(c->width, 640);
    EXPECT_EQ(c->height, 480);
    EXPECT_DOUBLE_EQ(c->cx, 320.0);
    EXPECT_DOUBLE_EQ(c->cy, 240.0);
  }
  EXPECT_DOUBLE_EQ(rig.range.depth_scale, 0.001);
  EXPECT_EQ(rig.range.invalid_values, (std::vector<int>{0, 65535}));
  EXPECT_EQ(rig.range.RawToMetres(65535), 0.0);
  EXPECT_DOUBLE_EQ(rig.range.RawToMetres(1234), 1.234);
  EXPECT_TRUE(rig.T_colour_range.isApprox(Eigen::Isometry3d::Identity()));
}

TEST(ShippedCalibration, SwissRangerPackageLooksLikeThePapers) {
  const Rig rig = ReadCalibration(DefaultCalibrationPath("sr3000_dragonfly2"));
  std::string why;
  EXPECT_TRUE(rig.Check(&why)) << why;
  EXPECT_FALSE(rig.registered);
  EXPECT_EQ(rig.colour.width, 1024);
  EXPECT_EQ(rig.colour.height, 768);
  EXPECT_EQ(rig.range.camera.width, 176);
  EXPECT_EQ(rig.range.camera.height, 144);
  EXPECT_EQ(rig.range.depth_kind, DepthKind::kRadial);
  EXPECT_DOUBLE_EQ(rig.range.max_range_m, 7.5);
  // Time-of-flight noise grows about 1% of range.
  EXPECT_NEAR(rig.range.noise.Sigma(5.0) - rig.range.noise.Sigma(4.0), 0.01, 0.002);
  // A few-cm baseline and a rotation orthonormal to machine precision after reading.
  const double baseline = rig.T_colour_range.translation().norm();
  EXPECT_GT(baseline, 0.01);
  EXPECT_LT(baseline, 0.10);
  const Eigen::Matrix3d R = rig.T_colour_range.linear();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  // The range imager sees a little more than the camera (paper §III).
  EXPECT_GT(rig.range.camera.width / rig.range.camera.fx, rig.colour.width / rig.colour.fx);
}

TEST(ShippedCalibration, EveryShippedFilePassesThePhysicalRanges) {
  for (const char* name : {"tum_fr1", "tum_fr2", "tum_fr3", "7scenes", "sr3000_dragonfly2"}) {
    EXPECT_NO_THROW(ReadCalibration(DefaultCalibrationPath(name))) << name;
  }
}

TEST(ShippedCalibration, DefaultPathPointsIntoDataCalib) {
  const std::string path = DefaultCalibrationPath("7scenes");
  EXPECT_EQ(path, std::string(IESLAM_SOURCE_DIR) + "/data/calib/7scenes.yaml");
  EXPECT_TRUE(fs::is_regular_file(path));
}

// Found by tests/fuzz/calibration_fuzz.cc: OpenCV's YAML parser threw std::length_error on
// this input (NUL bytes in a key), which escaped as an "internal error" instead of exit code 2.
TEST(CalibrationFuzzRegression, BinaryGarbageIsAConfigErrorNamingTheFile) {
  const std::string input(
      "%YAML:1.0\n---\n# The paper's senso;r package (, T-RO 2000\ncolour:\n  width: 44\n"
      "  :02\000 0.x0\n  fy: 200.0d\000\000\000\000\000\000\000\002istortion: [0.0, 0cya"
      "me: tum_fr3\nregistered: 1\npixel_sigma: ,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,,"
      ",,,,,,,,,,,,,,,,\000\000\365\365\365\365\365\365\365\365\365\000\000\000\000\000\000"
      "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000"
      "\000\000: 10.0\n  noi$se: {a: 0.0002, b: 0.0, c: 0.0016}\nT_.0]\n  dep\000\000cs:"
      " th T-RO 2000\ncolour:\n  width: 102c",
      364);
  try {
    ParseCalibration(input, "fuzzed.yaml");
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("fuzzed.yaml: not a text file (NUL byte at offset 82)"),
              std::string::npos)
        << e.what();
  }
}

// Found by tests/fuzz/calibration_fuzz.cc (now one of its seeds): cv::FileStorage::open never
// returned on this file (its root map is indented; see core/yaml_text.cc), so `ieslam run
// --calib` hung. Run in a child process that SIGALRM ends, so a regression fails, not stalls.
TEST(CalibrationFuzzRegressionDeathTest, IndentedRootIsAConfigErrorNotAHang) {
  const std::string path =
      std::string(IESLAM_SOURCE_DIR) + "/tests/fuzz/seeds/calibration_fuzz/regression-hang";
  EXPECT_EXIT(
      {
        alarm(10);
        try {
          ReadCalibration(path);
        } catch (const ConfigError& e) {
          std::fprintf(stderr, "%s\n", e.what());
          _exit(0);
        }
        _exit(1);
      },
      ::testing::ExitedWithCode(0), "regression-hang:2: expected a key in column 1");
}

}  // namespace
}  // namespace ieslam
