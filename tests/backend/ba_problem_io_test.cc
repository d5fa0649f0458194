#include "backend/ba_problem_io.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "ba_test_scene.h"
#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

// The same observations to the last bit, in the same order.
void ExpectSameObservations(const std::vector<BundleAdjustmentObservation>& read,
                            const std::vector<BundleAdjustmentObservation>& written) {
  ASSERT_EQ(read.size(), written.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].frame_id, written[i].frame_id) << i;
    EXPECT_EQ(read[i].observation.feature_id, written[i].observation.feature_id) << i;
    EXPECT_EQ(read[i].observation.z, written[i].observation.z) << i;
    EXPECT_EQ(read[i].observation.Q, written[i].observation.Q) << i;
  }
}

class BaProblemIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ieslam_ba_problem_io_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    std::mt19937 rng(3);
    const testing_ba::TestScene scene = testing_ba::MakeTestScene(5, 60, &rng);
    stored_.problem = testing_ba::MakeTestProblem(scene, 0.05, 0.02, 0.05, true, &rng);
    stored_.camera = scene.camera;
    for (const auto& [frame, T] : stored_.problem.T_w_c)
      stored_.timestamps[frame] = 10.0 + frame / 30.0;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const char* name) const { return (dir_ / name).string(); }

  // The lines of the stored problem as written.
  std::vector<std::string> WrittenLines() const {
    WriteBaProblem(Path("p.txt"), stored_);
    std::ifstream in(Path("p.txt"));
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
  }

  // Writes `lines` to p.txt and reads it back.
  StoredBaProblem ReadLines(const std::vector<std::string>& lines) const {
    std::ofstream out(Path("p.txt"), std::ios::trunc);
    for (const std::string& line : lines) out << line << "\n";
    out.close();
    return ReadBaProblem(Path("p.txt"));
  }

  // Writes the stored problem with `line` before its end line, and reads it back.
  StoredBaProblem ReadWithExtraLine(const std::string& line) const {
    std::vector<std::string> lines = WrittenLines();
    lines.insert(lines.end() - 1, line);
    return ReadLines(lines);
  }

  // The DataError's message of reading `lines` ("" when there is none).
  std::string ErrorReading(const std::vector<std::string>& lines) const {
    try {
      ReadLines(lines);
    } catch (const DataError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
  StoredBaProblem stored_;
};

TEST_F(BaProblemIoTest, RoundTripIsExactAndRefinesIdentically) {
  WriteBaProblem(Path("p.txt"), stored_);
  const StoredBaProblem back = ReadBaProblem(Path("p.txt"));
  ASSERT_EQ(back.problem.T_w_c.size(), stored_.problem.T_w_c.size());
  for (const auto& [frame, T] : stored_.problem.T_w_c) {
    EXPECT_EQ(back.problem.T_w_c.at(frame).matrix(), T.matrix()) << "pose " << frame;
    EXPECT_EQ(back.timestamps.at(frame), stored_.timestamps.at(frame));
  }
  EXPECT_EQ(back.problem.p_w, stored_.problem.p_w);
  ExpectSameObservations(back.problem.observations, stored_.problem.observations);
  EXPECT_EQ(back.problem.AnchorFrameId(), stored_.problem.AnchorFrameId());
  EXPECT_EQ(back.camera.fx, stored_.camera.fx);
  EXPECT_EQ(back.camera.cy, stored_.camera.cy);
  const BundleAdjustmentResult a = SolveBundleAdjustment(stored_.problem, stored_.camera, {});
  const BundleAdjustmentResult b = SolveBundleAdjustment(back.problem, back.camera, {});
  EXPECT_EQ(a.final_cost, b.final_cost);
  for (const auto& [frame, T] : a.T_w_c) EXPECT_EQ(b.T_w_c.at(frame).matrix(), T.matrix());
}

TEST_F(BaProblemIoTest, BadFilesNameTheFileAndLine) {
  auto expect_error = [&](const std::string& line, const std::string& part) {
    try {
      ReadWithExtraLine(line);
      ADD_FAILURE() << "no error for: " << line;
    } catch (const DataError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(Path("p.txt") + ":"), std::string::npos) << what;
      EXPECT_NE(what.find(part), std::string::npos) << what;
    }
  };
  expect_error("feature 7 1 2 nan", "not finite");
  expect_error("feature 7 1 2", "missing");
  const std::string frame = std::to_string(stored_.problem.T_w_c.begin()->first);
  const std::string id = std::to_string(stored_.problem.p_w.begin()->first);
  expect_error("obs 99999 " + id + " 300 200 1.5 1 0 0 1 0 0.0001", "unknown pose 99999");
  expect_error("obs " + frame + " " + id + " 300 200 1.5 1 0 0 -1 0 0.0001", "positive definite");
  expect_error("pose " + frame + " 1 1 0 0 0 1 0 0 0 1 0 0 0", "given twice");
  expect_error("pose 77 1 2 0 0 0 1 0 0 0 1 0 0 0", "no rotation matrix");
  expect_error("landmark 3 1 2 3", "unknown record 'landmark'");
  expect_error("feature 7 1 2 3 4", "unexpected value '4'");
  EXPECT_THROW(ReadBaProblem(Path("missing.txt")), DataError);
  std::ofstream(Path("empty.txt")) << "# nothing\n";
  EXPECT_THROW(ReadBaProblem(Path("empty.txt")), DataError);
}

TEST_F(BaProblemIoTest, AFileCutAtALineBoundaryIsRefusedNamingWhatIsMissing) {
  const std::vector<std::string> lines = WrittenLines();
  ASSERT_EQ(lines.back(), "end");
  // Half the observations gone: the count says so.
  std::vector<std::string> half(lines.begin(),
                                lines.end() - 1 - stored_.problem.observations.size() / 2);
  const std::string error = ErrorReading(half);
  EXPECT_NE(error.find(Path("p.txt")), std::string::npos) << error;
  EXPECT_NE(error.find("observations, the header says " +
                       std::to_string(stored_.problem.observations.size())),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("cut short"), std::string::npos) << error;
  // Every record there but the end line.
  const std::string no_end = ErrorReading({lines.begin(), lines.end() - 1});
  EXPECT_NE(no_end.find(Path("p.txt") + ": no end line"), std::string::npos) << no_end;
  // Nothing may follow the end line.
  std::vector<std::string> after = lines;
  after.push_back(lines[lines.size() - 2]);
  EXPECT_NE(ErrorReading(after).find("after the end line"), std::string::npos);
}

TEST_F(BaProblemIoTest, AnOlderOrUnknownVersionIsRefusedNamingIt) {
  std::vector<std::string> lines = WrittenLines();
  const auto header = std::find_if(lines.begin(), lines.end(), [](const std::string& line) {
    return line.rfind("ieslam_ba_problem ", 0) == 0;
  });
  ASSERT_NE(header, lines.end());
  *header = "ieslam_ba_problem 1";
  const std::string old = ErrorReading(lines);
  EXPECT_NE(old.find("version 1"), std::string::npos) << old;
  EXPECT_NE(old.find("re-run `ieslam run`"), std::string::npos) << old;
  *header = "ieslam_ba_problem 4 1 1 1 0";
  EXPECT_NE(ErrorReading(lines).find("unsupported version 4"), std::string::npos);
}

// The registered observations come back apart from the filter's; a version 2 file (none,
// three counts) is still read.
TEST_F(BaProblemIoTest, RegisteredObservationsRoundTripApartAndVersionTwoIsRead) {
  const size_t observations = stored_.problem.observations.size();
  stored_.problem.registered = stored_.problem.observations;
  stored_.problem.registered.back().observation.Q *= 4.0;
  stored_.problem.observations.resize(observations - 3);
  WriteBaProblem(Path("p.txt"), stored_);
  const StoredBaProblem back = ReadBaProblem(Path("p.txt"));
  ExpectSameObservations(back.problem.observations, stored_.problem.observations);
  ExpectSameObservations(back.problem.registered, stored_.problem.registered);
  // One registered observation fewer than the header counts: refused.
  std::vector<std::string> lines = WrittenLines();
  lines.erase(lines.end() - 2);
  const std::string error = ErrorReading(lines);
  EXPECT_NE(error.find(std::to_string(observations - 1) +
                       " registered observations, the header says " + std::to_string(observations)),
            std::string::npos)
      << error;

  stored_.problem.registered.clear();
  lines = WrittenLines();
  const auto header = std::find_if(lines.begin(), lines.end(), [](const std::string& line) {
    return line.rfind("ieslam_ba_problem ", 0) == 0;
  });
  ASSERT_NE(header, lines.end());
  *header = "ieslam_ba_problem 2 " + std::to_string(stored_.problem.T_w_c.size()) + " " +
            std::to_string(stored_.problem.p_w.size()) + " " + std::to_string(observations - 3);
  const StoredBaProblem old = ReadLines(lines);
  EXPECT_EQ(old.problem.observations.size(), observations - 3);
  EXPECT_TRUE(old.problem.registered.empty());
  // A version 2 header counts no registered observations.
  lines.insert(lines.end() - 1, lines[lines.size() - 2]);
  lines[lines.size() - 2].replace(0, 3, "registered");
  EXPECT_NE(ErrorReading(lines).find("1 registered observations, the header says 0"),
            std::string::npos);
}

TEST_F(BaProblemIoTest, AnObservationFarOutsideTheImageOrWithoutRangeIsRefused) {
  const std::string frame = std::to_string(stored_.problem.T_w_c.begin()->first);
  const std::string id = std::to_string(stored_.problem.p_w.begin()->first);
  for (const auto& [z, part] : std::vector<std::pair<std::string, std::string>>{
           {"1e308 200 1.5", "e+308, 200) lies farther outside"},
           {"300 -1e9 1.5", "outside the"},
           {"300 200 0", "range d = 0"}}) {
    try {
      ReadWithExtraLine("obs " + frame + " " + id + " " + z + " 1 0 0 1 0 0.0001");
      ADD_FAILURE() << "no error for " << z;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find(Path("p.txt") + ":"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace ieslam
