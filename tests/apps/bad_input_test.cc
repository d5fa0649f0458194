// Bad input, as a user meets it: the real `ieslam` binary on a small synthetic sequence with
// one kind of damage per test. Every case ends in a clean exit with the documented code
// (2 usage/config, 3 data) and a message naming the file, line or frame and
// the value, or, for a bad frame in the middle of a sequence, in a counted skip: the frame is
// listed in report.json's frames_skipped with its reason, a warning names it, and the run
// goes on to a good trajectory.
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "command_test_util.h"
#include "core/calibration.h"
#include "frontend/simulation/synthetic_dataset.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;
using testing_apps::ReadFile;
using testing_apps::RunIeslam;
using Result = testing_apps::CommandResult;

void WriteFile(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// `text` with the first `from` replaced by `to` (which must be there).
std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The `timestamp path` lines of a list, comments dropped.
std::vector<std::pair<std::string, std::string>> ListEntries(const fs::path& list) {
  std::vector<std::pair<std::string, std::string>> entries;
  std::ifstream in(list);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string stamp, path;
    fields >> stamp >> path;
    entries.emplace_back(stamp, path);
  }
  return entries;
}

constexpr int kFrames = 16;

class BadInputTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = fs::temp_directory_path() / ("ieslam_bad_input_test_" + std::to_string(::getpid()));
    fs::create_directories(root_);
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  // Only the tests that run the damaged sequence render images, once per process (ctest
  // runs this file as one process); the others need lists and small files only.
  static void RunDamagedSequence() {
    if (!damaged_report_.empty()) return;
    SyntheticDatasetOptions options;
    options.frames = kFrames;
    options.frames_per_loop = 300;  // hand-held motion: ~2 cm and ~1.5 deg per frame
    options.resolution_scale = 0.5;
    WriteSyntheticDataset(Good().string(), options);
    MakeDamagedSequence();
    damaged_run_ = RunIeslam("run --threads 1 --quiet --dataset " + (root_ / "damaged").string() +
                             " --output " + (root_ / "damaged_out").string());
    damaged_report_ = ReadFile(root_ / "damaged_out" / "report.json");
  }

  // A sequence of `frames` frames whose lists name images that are never written (opening
  // a dataset reads its lists, calibration and ground truth only), in root_/`name`.
  static fs::path ListsOnly(const std::string& name, int frames = 5) {
    const fs::path dir = root_ / name;
    fs::create_directories(dir);
    WriteCalibration((dir / "calib.yaml").string(), SyntheticRig(SyntheticSensor::kRgbd, 0.5));
    std::string rgb = "# colour images\n", depth = "# depth images\n", gt = "# ground truth\n";
    for (int i = 0; i < frames; ++i) {
      char stamp[32], stamp_depth[32];
      std::snprintf(stamp, sizeof(stamp), "%.6f", 1000.0 + i / 30.0);
      std::snprintf(stamp_depth, sizeof(stamp_depth), "%.6f", 1000.005 + i / 30.0);
      rgb += std::string(stamp) + " rgb/" + stamp + ".png\n";
      depth += std::string(stamp_depth) + " depth/" + stamp_depth + ".png\n";
      gt += std::string(stamp) + " " + std::to_string(0.01 * i) + " 0 0 0 0 0 1\n";
    }
    WriteFile(dir / "rgb.txt", rgb);
    WriteFile(dir / "depth.txt", depth);
    WriteFile(dir / "groundtruth.txt", gt);
    return dir;
  }

  static fs::path Good() { return root_ / "good"; }

  // A copy of the good sequence in root_/`name` whose lists point at the good images
  // (absolute paths), so that single images can be replaced in the copy.
  static fs::path CopyOfGood(const std::string& name) {
    const fs::path dir = root_ / name;
    fs::create_directories(dir / "rgb");
    fs::create_directories(dir / "depth");
    for (const char* file : {"calib.yaml", "groundtruth.txt"}) {
      fs::copy_file(Good() / file, dir / file, fs::copy_options::overwrite_existing);
    }
    for (const char* list : {"rgb.txt", "depth.txt"}) {
      std::string text;
      for (const auto& [stamp, path] : ListEntries(Good() / list)) {
        text += stamp + " " + (Good() / path).string() + "\n";
      }
      WriteFile(dir / list, text);
    }
    return dir;
  }

  // Points frame `frame` of `list` in `dir` at `image_name` inside `dir` and returns its path.
  static fs::path Redirect(const fs::path& dir, const char* list, int frame,
                           const std::string& image_name) {
    auto entries = ListEntries(dir / list);
    const fs::path target = dir / image_name;
    entries[frame].second = target.string();
    std::string text;
    for (const auto& [stamp, path] : entries) text += stamp + " " + path + "\n";
    WriteFile(dir / list, text);
    return target;
  }

  static fs::path GoodImage(const char* list, int frame) {
    return Good() / ListEntries(Good() / list)[frame].second;
  }

  // One damaged frame of each kind in the middle of the sequence.
  static void MakeDamagedSequence() {
    const fs::path dir = CopyOfGood("damaged");
    // Frame 3: random bytes under a .png name.
    corrupt_ = Redirect(dir, "rgb.txt", 3, "rgb/corrupt.png");
    std::mt19937 rng(3);
    std::string garbage;
    for (int i = 0; i < 5000; ++i) garbage.push_back(static_cast<char>(rng() & 0xff));
    WriteFile(corrupt_, garbage);
    // Frame 5: a depth PNG cut off half-way (an interrupted copy).
    truncated_ = Redirect(dir, "depth.txt", 5, "depth/truncated.png");
    const std::string png = ReadFile(GoodImage("depth.txt", 5));
    WriteFile(truncated_, png.substr(0, png.size() / 2));
    // Frame 7: a depth image of the wrong size.
    wrong_size_ = Redirect(dir, "depth.txt", 7, "depth/small.png");
    const cv::Mat depth = cv::imread(GoodImage("depth.txt", 7).string(), cv::IMREAD_UNCHANGED);
    cv::imwrite(wrong_size_.string(),
                depth(cv::Rect(0, 0, depth.cols / 2, depth.rows / 2)).clone());
    // Frame 9: a depth image with no measurement at all.
    zero_depth_ = Redirect(dir, "depth.txt", 9, "depth/zero.png");
    cv::imwrite(zero_depth_.string(), cv::Mat::zeros(depth.size(), CV_16UC1));
    // Frames 11 and 12: the camera sees a blank wall.
    for (int frame : {11, 12}) {
      textureless_.push_back(
          Redirect(dir, "rgb.txt", frame, "rgb/blank" + std::to_string(frame) + ".png"));
      cv::imwrite(textureless_.back().string(),
                  cv::Mat(depth.size(), CV_8UC3, cv::Scalar(128, 128, 128)));
    }
  }

  // The reason report.json gives for skipping `frame` ("" when it is not listed).
  // The reason of `frame`'s entry in frames_skipped (other lists name frames too).
  static std::string SkipReason(int frame) {
    const size_t list = damaged_report_.find("\"frames_skipped\": [");
    const size_t end = damaged_report_.find(']', list);
    if (list == std::string::npos || end == std::string::npos) return "";
    const std::string key = "\"frame\": " + std::to_string(frame) + ",";
    const size_t at = damaged_report_.find(key, list);
    if (at == std::string::npos || at > end) return "";
    const size_t start = damaged_report_.find("\"reason\": \"", at);
    if (start == std::string::npos) return "";
    const size_t begin = start + 11;
    return damaged_report_.substr(begin, damaged_report_.find('"', begin) - begin);
  }

  // The skip is listed with a reason holding every part, and warned about on the terminal.
  static void ExpectSkipped(int frame, const std::vector<std::string>& parts) {
    const std::string reason = SkipReason(frame);
    ASSERT_FALSE(reason.empty()) << "frame " << frame << " not in frames_skipped:\n"
                                 << damaged_report_.substr(0, 2000);
    for (const std::string& part : parts) {
      ASSERT_FALSE(part.empty());
      EXPECT_TRUE(Contains(reason, part)) << "reason: " << reason << "\nlacks: " << part;
    }
    EXPECT_TRUE(Contains(damaged_run_.output,
                         "run: warning: frame " + std::to_string(frame) + " skipped: "))
        << damaged_run_.output;
  }

  static fs::path root_;
  static Result damaged_run_;
  static std::string damaged_report_;
  static fs::path corrupt_, truncated_, wrong_size_, zero_depth_;
  static std::vector<fs::path> textureless_;
};
fs::path BadInputTest::root_;
Result BadInputTest::damaged_run_;
std::string BadInputTest::damaged_report_;
fs::path BadInputTest::corrupt_, BadInputTest::truncated_, BadInputTest::wrong_size_,
    BadInputTest::zero_depth_;
std::vector<fs::path> BadInputTest::textureless_;

// ------------------------------------------------- bad frames mid-sequence: counted skips

// The damaged run (and the paths its assertions name) must exist before a test body builds
// its expectations, also when a test runs alone (--gtest_filter).
class DamagedSequenceTest : public BadInputTest {
 protected:
  void SetUp() override { RunDamagedSequence(); }
};

TEST_F(DamagedSequenceTest, DamagedFramesAreSkippedAndTheRunStillTracks) {
  ASSERT_EQ(damaged_run_.exit_code, 0) << damaged_run_.output;
  EXPECT_TRUE(Contains(damaged_run_.output, "6 skipped")) << damaged_run_.output;
  EXPECT_TRUE(Contains(damaged_report_, "\"interrupted\": false"));
  // Only the damaged frames are skipped, and the others are tracked as well as ever.
  for (int frame = 0; frame < kFrames; ++frame) {
    const bool damaged =
        frame == 3 || frame == 5 || frame == 7 || frame == 9 || frame == 11 || frame == 12;
    EXPECT_EQ(SkipReason(frame).empty(), !damaged) << frame << ": " << SkipReason(frame);
  }
  const Result evaluated =
      RunIeslam("evaluate --gt " + (root_ / "damaged_out/groundtruth.tum").string() + " --est " +
                (root_ / "damaged_out/trajectory.tum").string() + " --delta 1 --delta-unit f");
  ASSERT_EQ(evaluated.exit_code, 0) << evaluated.output;
  EXPECT_TRUE(Contains(evaluated.output, "ate.pairs 10\n")) << evaluated.output;
  const size_t at = evaluated.output.find("ate.rmse ");
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(std::stod(evaluated.output.substr(at + 9)), 0.03) << evaluated.output;
}

TEST_F(DamagedSequenceTest, CorruptImageIsASkipNamingTheFile) {
  ExpectSkipped(3, {"frame 3", "cannot decode colour image", corrupt_.string()});
}

TEST_F(DamagedSequenceTest, TruncatedImageIsASkipNamingTheFile) {
  ExpectSkipped(5, {"frame 5", "range image", truncated_.string()});
}

TEST_F(DamagedSequenceTest, WrongSizeImageIsASkipNamingFileAndSizes) {
  ExpectSkipped(
      7, {"frame 7", wrong_size_.string() + " is 160x120 but calibration", "expects 320x240"});
}

TEST_F(DamagedSequenceTest, AllZeroDepthIsASkipNamingTheFile) {
  ExpectSkipped(9, {"frame 9", zero_depth_.string(), "no valid measurement"});
}

TEST_F(DamagedSequenceTest, TexturelessFramesAreSkipsNamingTheFile) {
  ExpectSkipped(11, {"frame 11", "too little texture", textureless_[0].string()});
  ExpectSkipped(12, {"frame 12", "too little texture", textureless_[1].string()});
}

// With --first, frames keep their dataset index in frames_skipped, in the reasons and in the
// warnings, as in selected_frames.txt.
TEST_F(DamagedSequenceTest, SkippedFramesKeepTheirDatasetIndexAfterFirst) {
  const fs::path out = root_ / "damaged_first";
  const Result r = RunIeslam("run --quiet --dataset " + (root_ / "damaged").string() +
                             " --first 2 --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string report = ReadFile(out / "report.json");
  EXPECT_TRUE(Contains(report, "\"frame\": 3,")) << report.substr(0, 3000);
  EXPECT_TRUE(Contains(report, "\"reason\": \"frame 3: cannot decode colour image"))
      << report.substr(0, 3000);
  EXPECT_FALSE(Contains(report, "\"frame\": 1,")) << report.substr(0, 3000);
  EXPECT_TRUE(Contains(r.output, "run: warning: frame 3 skipped: frame 3: cannot decode"))
      << r.output;
  EXPECT_EQ(ReadFile(out / "selected_frames.txt").rfind("2 ", 0), 0u);
}

TEST_F(BadInputTest, ABadFirstFrameEndsTheRunWithExit3) {
  const fs::path dir = ListsOnly("bad_first");
  const fs::path image = dir / ListEntries(dir / "rgb.txt")[0].second;
  fs::create_directories(image.parent_path());
  WriteFile(image, "not a png");
  const Result r =
      RunIeslam("run --quiet --dataset " + dir.string() + " --output " + (root_ / "o1").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output,
                       "the first frame cannot start the map: frame 0: cannot decode "
                       "colour image " +
                           image.string()))
      << r.output;
}

TEST_F(BadInputTest, OnlyTheFirstFrameUsableStillWritesEveryOutput) {
  // Frame 0 is fine (texture at 1.5 m); the images of frames 1..4 are missing.
  const fs::path dir = ListsOnly("first_only");
  const Rig rig = SyntheticRig(SyntheticSensor::kRgbd, 0.5);
  cv::Mat colour(rig.colour.height, rig.colour.width, CV_8UC3);
  cv::RNG rng(5);
  rng.fill(colour, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(colour, colour, cv::Size(5, 5), 1.5);
  const fs::path colour_path = dir / ListEntries(dir / "rgb.txt")[0].second;
  const fs::path depth_path = dir / ListEntries(dir / "depth.txt")[0].second;
  fs::create_directories(colour_path.parent_path());
  fs::create_directories(depth_path.parent_path());
  ASSERT_TRUE(cv::imwrite(colour_path.string(), colour));
  const cv::Mat depth(colour.size(), CV_16UC1,
                      cv::Scalar(static_cast<int>(1.5 / rig.range.depth_scale)));
  ASSERT_TRUE(cv::imwrite(depth_path.string(), depth));
  const fs::path out = root_ / "first_only_out";
  const Result r = RunIeslam("run --quiet --dataset " + dir.string() + " --output " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Contains(r.output, "4 skipped")) << r.output;
  EXPECT_TRUE(Contains(r.output, "run: warning: frame 4 skipped: frame 4: colour image not found"))
      << r.output;
  // Too few poses for an ATE: a warning, and the report leaves it out rather than failing.
  EXPECT_TRUE(Contains(r.output, "run: warning: no ATE for keyframes.tum: only 1 poses"))
      << r.output;
  const std::string report = ReadFile(out / "report.json");
  EXPECT_TRUE(Contains(report, "\"frames_selected\": 1")) << report.substr(0, 1500);
  EXPECT_FALSE(Contains(report, "\"keyframes\": "));
  for (const char* file : {"keyframes.tum", "trajectory.tum", "map.ply"}) {
    EXPECT_TRUE(fs::is_regular_file(out / file)) << file;
  }
}

// ------------------------------------------------- bad datasets and files: clean exits

TEST_F(BadInputTest, MissingDatasetIsExit3NamingIt) {
  const std::string missing = (root_ / "no_such_sequence").string();
  const Result r = RunIeslam("run --dataset " + missing + " --output " + (root_ / "o2").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, "dataset directory not found: " + missing)) << r.output;
}

TEST_F(BadInputTest, MissingListFileIsExit3NamingIt) {
  const fs::path dir = ListsOnly("no_depth_list");
  fs::remove(dir / "depth.txt");
  Result r = RunIeslam("run --format tum --dataset " + dir.string() + " --output " +
                       (root_ / "o3").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, "image list not found: " + (dir / "depth.txt").string()))
      << r.output;
  // Without --format, the layout is not recognised, and the message says what was looked for.
  r = RunIeslam("run --dataset " + dir.string() + " --output " + (root_ / "o3").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, "rgb.txt + depth.txt (tum)")) << r.output;
}

TEST_F(BadInputTest, DuplicateTimestampIsExit3NamingFileAndLine) {
  const fs::path dir = ListsOnly("duplicate");
  auto entries = ListEntries(dir / "rgb.txt");
  std::string text = "# colour\n";
  for (int i = 0; i < static_cast<int>(entries.size()); ++i) {
    text += (i == 4 ? entries[3].first : entries[i].first) + " " + entries[i].second + "\n";
  }
  WriteFile(dir / "rgb.txt", text);
  const Result r =
      RunIeslam("run --dataset " + dir.string() + " --output " + (root_ / "o4").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, (dir / "rgb.txt").string() + ":6: duplicate timestamp " +
                                     entries[3].first + " (also on line 5)"))
      << r.output;
}

TEST_F(BadInputTest, UnsortedTimestampsAreExit3NamingFileAndLine) {
  const fs::path dir = ListsOnly("unsorted", 10);
  auto entries = ListEntries(dir / "depth.txt");
  std::swap(entries[6], entries[7]);
  std::string text;
  for (const auto& [stamp, path] : entries) text += stamp + " " + path + "\n";
  WriteFile(dir / "depth.txt", text);
  const Result r =
      RunIeslam("run --dataset " + dir.string() + " --output " + (root_ / "o5").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(
      Contains(r.output, (dir / "depth.txt").string() + ":8: timestamps must increase strictly"))
      << r.output;
}

TEST_F(BadInputTest, NanInGroundTruthIsExit3NamingFileAndLine) {
  const fs::path dir = ListsOnly("nan_gt");
  std::string gt = ReadFile(dir / "groundtruth.txt");
  std::istringstream lines(gt);
  std::string line, text;
  int number = 0, changed = 0;
  while (std::getline(lines, line)) {
    ++number;
    if (changed == 0 && !line.empty() && line[0] != '#') {
      std::istringstream fields(line);
      std::string stamp;
      fields >> stamp;
      line = stamp + " 0.1 nan 0.3 0 0 0 1";
      changed = number;
    }
    text += line + "\n";
  }
  WriteFile(dir / "groundtruth.txt", text);
  const Result r =
      RunIeslam("run --dataset " + dir.string() + " --output " + (root_ / "o6").string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, (dir / "groundtruth.txt").string() + ":" +
                                     std::to_string(changed) + ": non-finite value 'nan'"))
      << r.output;
}

TEST_F(BadInputTest, InfInATrajectoryToEvaluateIsExit3NamingFileAndLine) {
  const fs::path est = root_ / "inf.tum";
  WriteFile(est, "# estimate\n1000.0 0 0 0 0 0 0 1\n1000.1 0 inf 0 0 0 0 1\n");
  const Result r = RunIeslam("evaluate --gt " + (ListsOnly("gt") / "groundtruth.txt").string() +
                             " --est " + est.string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, est.string() + ":3")) << r.output;
  EXPECT_TRUE(Contains(r.output, "inf")) << r.output;
}

TEST_F(BadInputTest, EmptyTrajectoryIsExit3NamingIt) {
  const fs::path est = root_ / "empty.tum";
  WriteFile(est, "# nothing estimated\n");
  const Result r = RunIeslam("evaluate --gt " + (ListsOnly("gt") / "groundtruth.txt").string() +
                             " --est " + est.string());
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_TRUE(Contains(r.output, est.string() + ": 0 poses")) << r.output;
}

TEST_F(BadInputTest, NanOrInfInCalibrationIsExit2NamingFileAndKey) {
  for (const char* value : {".nan", ".inf"}) {
    const fs::path dir = ListsOnly(std::string("nan_calib") + (value[1] == 'n' ? "1" : "2"));
    const std::string calib = ReadFile(dir / "calib.yaml");
    const size_t at = calib.find("fx: ");
    ASSERT_NE(at, std::string::npos);
    const std::string old_fx = calib.substr(at, calib.find('\n', at) - at);
    WriteFile(dir / "calib.yaml", Replace(calib, old_fx, std::string("fx: ") + value));
    const Result r =
        RunIeslam("run --dataset " + dir.string() + " --output " + (root_ / "o7").string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_TRUE(
        Contains(r.output, (dir / "calib.yaml").string() + ": key 'colour.fx' must be finite"))
        << r.output;
  }
}

// `ieslam args` as RunIeslam, ended after 60 s (exit code 124) should it hang.
Result RunIeslamWithTimeout(const std::string& args) {
  Result result;
  FILE* pipe = popen(("timeout 60 " IESLAM_BINARY " " + args + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) {
    result.output.append(buffer.data(), n);
  }
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

// A FIFO would block the read forever and /dev/zero never ends; a calibration nested
// 50 000 deep overflowed OpenCV's recursive parser (exit 139).
TEST_F(BadInputTest, CalibrationThatIsAFifoOrNestedTooDeepIsExit2NamingIt) {
  const std::string common = "run --dataset " + ListsOnly("calib_kinds").string() + " --output " +
                             (root_ / "o10").string() + " --calib ";
  const std::string fifo = (root_ / "calib.fifo").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  Result r = RunIeslamWithTimeout(common + fifo);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, "calibration file is not a regular file: " + fifo)) << r.output;
  r = RunIeslamWithTimeout(common + "/dev/zero");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, "calibration file is not a regular file: /dev/zero")) << r.output;
  const fs::path deep = root_ / "deep.yaml";
  WriteFile(deep, "%YAML:1.0\n---\na: " + std::string(50000, '['));
  r = RunIeslamWithTimeout(common + deep.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, deep.string() + ":3: nesting deeper than 64 levels")) << r.output;
  EXPECT_FALSE(fs::exists(root_ / "o10" / "report.json"));
}

TEST_F(BadInputTest, OutOfRangeOptionsAreExit2NamingTheFlag) {
  const std::string common =
      "run --dataset " + ListsOnly("options").string() + " --output " + (root_ / "o8").string();
  const std::pair<const char*, const char*> cases[] = {
      {"--buffer -4", "--buffer must be in [1, 100], got -4"},
      {"--buffer 0", "--buffer must be in [1, 100], got 0"},
      {"--stride 0", "--stride"},
      {"--first -1", "--first"},
      {"--threads -2", "--threads"},
      {"--seed abc", "--seed must be an integer, got 'abc'"},
      {"--selector best", "--selector must be one of info|all|interval|deadreckoning, got 'best'"},
      {"--format bag", "bag"},
      // Refused before any frame is read (the lists-only dataset has no images).
      {"--selector deadreckoning --refine", "--refine needs a filter"},
  };
  for (const auto& [flags, message] : cases) {
    const Result r = RunIeslam(common + " " + flags);
    EXPECT_EQ(r.exit_code, 2) << flags << "\n" << r.output;
    EXPECT_TRUE(Contains(r.output, message)) << flags << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(root_ / "o8" / "report.json"));
}

// simulate takes --config as run does, checked before any work.
TEST_F(BadInputTest, SimulateConfigIsCheckedNamingFileAndKey) {
  const fs::path config = root_ / "bad_ba.yaml";
  WriteFile(config, "ba:\n  rejection_chi2: -1\n");
  const fs::path out = root_ / "o9";
  Result r = RunIeslam("simulate --output " + out.string() + " --config " + config.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, config.string() + ": ba.rejection_chi2 must be >= 0.0, got -1.0"))
      << r.output;
  const std::string missing = (root_ / "no_such.yaml").string();
  // A config file that is missing or a directory is bad usage, as --calib's is.
  r = RunIeslam("simulate --output " + out.string() + " --config " + missing);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, "config file not found: " + missing)) << r.output;
  r = RunIeslam("simulate --output " + out.string() + " --config " + root_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_TRUE(Contains(r.output, "config file is not a regular file: " + root_.string()))
      << r.output;
  EXPECT_FALSE(fs::exists(out / "report.json"));
}

}  // namespace
}  // namespace ieslam
