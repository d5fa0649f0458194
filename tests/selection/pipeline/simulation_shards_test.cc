// Shards of a Monte-Carlo study, written, read back and merged, against one process.
#include "selection/pipeline/simulation_shards.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "core/error.h"

namespace ieslam {
namespace {

SimulationStudyOptions ShortStudy(int first_run, int runs) {
  SimulationStudyOptions options;
  options.simulation.trajectory.num_poses = 40;
  options.simulation.trajectory.num_loops = 1;
  options.buffers = {3};
  options.first_run = first_run;
  options.runs = runs;
  return options;
}

// Writes `text` as DIR/runs.tsv in a fresh temporary directory; returns the file.
std::string WriteRuns(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("ieslam_shards_test_" + std::to_string(::getpid())) / name;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "runs.tsv").string();
  std::ofstream(path) << text;
  return path;
}

// The wall times of `from`'s runs into `to`'s: they are measured, not drawn from the seeds.
void CopyTimes(const SimulationStudy& from, int first, SimulationStudy* to) {
  for (size_t i = 0; i < to->row_runs.size(); ++i) {
    for (size_t r = 0; r < to->row_runs[i].runs.size(); ++r) {
      const StudyRunValues& f = from.row_runs[i].runs[first + r];
      StudyRunValues& t = to->row_runs[i].runs[r];
      t.seconds = f.seconds;
      t.seconds_selection = f.seconds_selection;
      t.seconds_filter = f.seconds_filter;
      t.seconds_ba = f.seconds_ba;
    }
  }
}

void ExpectSameRow(const StudyRow& a, const StudyRow& b) {
  EXPECT_EQ(a.selector, b.selector);
  EXPECT_EQ(a.buffer, b.buffer);
  EXPECT_EQ(a.frames_total, b.frames_total);
  EXPECT_EQ(a.frames_used, b.frames_used);
  EXPECT_EQ(a.state_dim, b.state_dim);
  EXPECT_EQ(a.seconds, b.seconds);
  EXPECT_EQ(a.final_pose_error_m, b.final_pose_error_m);
  EXPECT_EQ(a.ate_rmse_m, b.ate_rmse_m);
  EXPECT_EQ(a.mean_nees, b.mean_nees);
  EXPECT_EQ(a.within_2sigma, b.within_2sigma);
  EXPECT_EQ(a.refined_ate_rmse_m, b.refined_ate_rmse_m);
  EXPECT_EQ(a.refined_not_worse, b.refined_not_worse);
  EXPECT_EQ(a.nees_band, b.nees_band);
}

class SimulationShardsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    one_ = new SimulationStudy(RunSimulationStudy(ShortStudy(0, 3)));
    first_ = new SimulationStudy(RunSimulationStudy(ShortStudy(0, 2)));
    second_ = new SimulationStudy(RunSimulationStudy(ShortStudy(2, 1)));
    CopyTimes(*one_, 0, first_);
    CopyTimes(*one_, 2, second_);
  }
  static void TearDownTestSuite() {
    delete one_;
    delete first_;
    delete second_;
  }
  static SimulationStudy* one_;
  static SimulationStudy* first_;
  static SimulationStudy* second_;
};
SimulationStudy* SimulationShardsTest::one_ = nullptr;
SimulationStudy* SimulationShardsTest::first_ = nullptr;
SimulationStudy* SimulationShardsTest::second_ = nullptr;

TEST_F(SimulationShardsTest, TwoShardsMergeToTheTableOfOneProcess) {
  const std::string a = WriteRuns("a", StudyRunsTsv(*first_, ShortStudy(0, 2)));
  const std::string b = WriteRuns("b", StudyRunsTsv(*second_, ShortStudy(2, 1)));
  // In any order.
  const StudyShard merged = MergeStudyShards({ReadStudyRunsTsv(b), ReadStudyRunsTsv(a)});
  EXPECT_EQ(merged.study.first_run, 0);
  EXPECT_EQ(merged.study.runs_done, 3);
  ASSERT_EQ(merged.study.rows.size(), one_->rows.size());
  for (size_t i = 0; i < one_->rows.size(); ++i) ExpectSameRow(merged.study.rows[i], one_->rows[i]);
  EXPECT_EQ(StudyMarkdown(merged.study, ShortStudy(0, 3)), StudyMarkdown(*one_, ShortStudy(0, 3)));
  EXPECT_EQ(StudyRowsToJson(merged.study.rows).Dump(), StudyRowsToJson(one_->rows).Dump());
  EXPECT_EQ(StudyRunsTsv(merged.study, ShortStudy(0, 3)), StudyRunsTsv(*one_, ShortStudy(0, 3)));
}

TEST_F(SimulationShardsTest, OverlappingGappedOrDisagreeingShardsNameTheFile) {
  const std::string a = WriteRuns("a", StudyRunsTsv(*first_, ShortStudy(0, 2)));
  const std::string b = WriteRuns("b", StudyRunsTsv(*second_, ShortStudy(2, 1)));
  auto message = [](const std::vector<std::string>& paths) -> std::string {
    std::vector<StudyShard> shards;
    for (const std::string& p : paths) shards.push_back(ReadStudyRunsTsv(p));
    try {
      MergeStudyShards(shards);
    } catch (const DataError& e) {
      return e.what();
    }
    return "";
  };
  const std::string overlap = message({a, a});
  EXPECT_NE(overlap.find("overlap"), std::string::npos) << overlap;
  EXPECT_NE(overlap.find(a), std::string::npos) << overlap;
  SimulationStudy gap = *second_;
  gap.first_run = 3;
  const std::string c = WriteRuns("c", StudyRunsTsv(gap, ShortStudy(3, 1)));
  EXPECT_NE(message({a, c}).find("gap"), std::string::npos);
  SimulationStudyOptions other_seed = ShortStudy(2, 1);
  other_seed.seed = 7;
  const std::string d = WriteRuns("d", StudyRunsTsv(*second_, other_seed));
  const std::string seed = message({a, d});
  EXPECT_NE(seed.find(d + ": seed 7"), std::string::npos) << seed;
  SimulationStudyOptions other_filter = ShortStudy(2, 1);
  other_filter.selector.map_gain_threshold *= 2.0;
  const std::string e = WriteRuns("e", StudyRunsTsv(*second_, other_filter));
  EXPECT_NE(message({a, e}).find(e + ": options"), std::string::npos);
}

TEST_F(SimulationShardsTest, ATruncatedRunsFileNamesTheFile) {
  std::string text = StudyRunsTsv(*first_, ShortStudy(0, 2));
  text.erase(text.rfind('\n', text.size() - 2) + 1);  // the last line
  const std::string a = WriteRuns("truncated", text);
  try {
    ReadStudyRunsTsv(a);
    ADD_FAILURE() << "no error";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(a + ": truncated"), std::string::npos) << e.what();
  }
  text.erase(text.size() - 20);  // mid-line
  const std::string b = WriteRuns("cut", text);
  EXPECT_THROW(ReadStudyRunsTsv(b), DataError);
}

}  // namespace
}  // namespace ieslam
