#include "backend/evaluation/evaluation_io.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/trajectory.h"

namespace ieslam {
namespace {

const std::string kTumEvalDir = std::string(IESLAM_SHARED_DATA_DIR) + "/tum-eval/";

TEST(EvaluationIo, FormatAndJsonCarryTheNumbers) {
  const EvaluationResult result =
      EvaluateTrajectoryFiles(kTumEvalDir + "fr2_desk_groundtruth.txt",
                              kTumEvalDir + "fr2_desk_ORB.txt", EvaluationOptions());
  ASSERT_EQ(result.warnings.size(), 1u);
  EXPECT_NE(result.warnings[0].find("fr2_desk_groundtruth.txt: 1 repeated"), std::string::npos)
      << result.warnings[0];
  const std::string text = FormatEvaluation(result);
  EXPECT_NE(text.find("ate.pairs 2223\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ate.rmse 0.008144\n"), std::string::npos) << text;
  EXPECT_NE(text.find("ate.median 0.007432\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.pairs 1998\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.trans.rmse 0.007161\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.rot.rmse 0.455005\n"), std::string::npos) << text;
  // Exactly the ten keys `ieslam evaluate` prints, in their order.
  const char* keys[] = {"ate.pairs", "ate.rmse", "ate.mean",  "ate.median",     "ate.std",
                        "ate.min",   "ate.max",  "rpe.pairs", "rpe.trans.rmse", "rpe.rot.rmse"};
  std::size_t at = 0;
  for (const char* key : keys) {
    ASSERT_EQ(text.compare(at, std::string(key).size() + 1, std::string(key) + " "), 0) << key;
    at = text.find('\n', at) + 1;
  }
  EXPECT_EQ(at, text.size());

  const std::string json = EvaluationToJson(result);
  EXPECT_NE(json.find("\"pairs\": 2223,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"pairs\": 1998,"), std::string::npos) << json;
  EXPECT_NE(json.find("\"trans\": {"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rot\": {"), std::string::npos) << json;
  // The first "rmse" is the ATE's and reads back to the same double.
  const std::size_t rmse = json.find("\"rmse\": ");
  ASSERT_NE(rmse, std::string::npos);
  EXPECT_EQ(std::strtod(json.c_str() + rmse + 8, nullptr), result.ate.translation.rmse);

  EXPECT_EQ(result.aligned_estimate.size(),
            ReadTumTrajectoryForEvaluation(kTumEvalDir + "fr2_desk_ORB.txt").size());
}

TEST(EvaluationIo, WhatCouldNotBeComputedKeepsItsPairCountAndItsReason) {
  EvaluationResult result;
  result.ate.translation = {3, 0.5, 0.25, 0.125, 1.0, 0.0, 2.0};
  result.rpe_unavailable = "only 0 relative-pose pairs";
  const std::string text = FormatEvaluation(result);
  EXPECT_EQ(text.rfind("ate.pairs 3\n", 0), 0u) << text;
  EXPECT_NE(text.find("ate.max 2.000000\n"), std::string::npos) << text;
  EXPECT_NE(text.find("rpe.pairs 0\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("rpe.trans"), std::string::npos) << text;
  const std::string json = EvaluationToJson(result);
  EXPECT_NE(
      json.find("\"rpe\": {\n    \"pairs\": 0,\n    \"trans\": null,\n    \"rot\": null\n  },"),
      std::string::npos)
      << json;
  EXPECT_NE(json.find("\"unavailable\": {\n    \"rpe\": \"only 0 relative-pose pairs\""),
            std::string::npos)
      << json;
  EXPECT_NE(json.find("\"pairs\": 3,"), std::string::npos) << json;
}

TEST(EvaluationIo, JsonLayoutIsFixed) {
  // Integral numbers print without a point, as evaluation.json always has.
  EvaluationResult result;
  result.ate.translation = {3, 0.5, 0.25, 0.125, 1.0, 0.0, 2.0};
  result.rpe.translation = {2, 1.5, 1.0, 1.0, 0.5, 0.5, 1.5};
  result.rpe.rotation = ScaleErrorStats(result.rpe.translation, 2.0);
  result.options.offset_s = -0.5;
  result.options.delta_unit = DeltaUnit::kFrames;
  EXPECT_EQ(EvaluationToJson(result), R"({
  "ate": {
    "pairs": 3,
    "rmse": 0.5,
    "mean": 0.25,
    "median": 0.125,
    "std": 1,
    "min": 0,
    "max": 2
  },
  "rpe": {
    "pairs": 2,
    "trans": {
      "rmse": 1.5,
      "mean": 1,
      "median": 1,
      "std": 0.5,
      "min": 0.5,
      "max": 1.5
    },
    "rot": {
      "rmse": 3,
      "mean": 2,
      "median": 2,
      "std": 1,
      "min": 1,
      "max": 3
    }
  },
  "options": {
    "max_diff_s": 0.02,
    "offset_s": -0.5,
    "scale": 1,
    "delta": 1,
    "delta_unit": "f"
  }
}
)");
}

TEST(EvaluationIo, ReaderSortsAndKeepsTheLastOfRepeatedStamps) {
  const std::string path = ::testing::TempDir() + "evaluation_test_repeats.txt";
  {
    std::ofstream out(path);
    out << "# t tx ty tz qx qy qz qw\n"
        << "2.0 2 0 0 0 0 0 1\n"
        << "1.0 1 0 0 0 0 0 1\n"
        << "\n"
        << "2.0,5,0,0,0,0,0,1\n"  // repeats 2.0: wins, as the later line of TUM's dict
        << "3.0\t3 0 0 0 0 0 1\n";
  }
  std::vector<std::string> warnings;
  const Trajectory trajectory = ReadTumTrajectoryForEvaluation(path, &warnings);
  ASSERT_EQ(trajectory.size(), 3u);
  EXPECT_EQ(trajectory[0].timestamp, 1.0);
  EXPECT_EQ(trajectory[1].timestamp, 2.0);
  EXPECT_EQ(trajectory[1].T_w_c.translation().x(), 5.0);
  EXPECT_EQ(trajectory[2].T_w_c.translation().x(), 3.0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find(path), std::string::npos);
  {
    std::ofstream out(path);
    out << "1.0 1 0 0 0 0 0 1\n1.5 1 0 zero 0 0 0 1\n";
  }
  try {
    ReadTumTrajectoryForEvaluation(path);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ":2"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(EvaluationIo, MissingFileIsADataErrorNamingIt) {
  const std::string missing = kTumEvalDir + "no_such_estimate.txt";
  try {
    EvaluateTrajectoryFiles(kTumEvalDir + "fr2_desk_groundtruth.txt", missing, EvaluationOptions());
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_estimate.txt"), std::string::npos) << e.what();
  }
}

// A trajectory read back in memory is the one `ieslam evaluate` reads from its file.
TEST(EvaluationIo, ReadBackInMemoryEqualsReadingTheWrittenFile) {
  Trajectory trajectory;
  for (int i = 0; i < 5; ++i) {
    TimedPose pose;
    pose.timestamp = 1305031102.175304 + 0.0333333333 * i;
    pose.T_w_c = Eigen::AngleAxisd(0.1234567891 * i, Eigen::Vector3d(1, 2, 3).normalized());
    pose.T_w_c.translation() = Eigen::Vector3d(0.1234567891234, -2.0 / 3.0, 1e-7 * i);
    trajectory.push_back(pose);
  }
  const std::string path = ::testing::TempDir() + "/ieslam_read_back.tum";
  WriteTumTrajectory(path, trajectory, "comment");
  const Trajectory from_file = ReadTumTrajectoryForEvaluation(path);
  const Trajectory in_memory = AsReadBackFromTum(trajectory, "trajectory");
  ASSERT_EQ(in_memory.size(), from_file.size());
  for (size_t i = 0; i < in_memory.size(); ++i) {
    EXPECT_EQ(in_memory[i].timestamp, from_file[i].timestamp);
    EXPECT_EQ(in_memory[i].T_w_c.matrix(), from_file[i].T_w_c.matrix());
    // The rounding is the file's: not the values given.
    EXPECT_NE(in_memory[i].T_w_c.translation().x(), trajectory[i].T_w_c.translation().x());
  }
  std::remove(path.c_str());
}

}  // namespace
}  // namespace ieslam
