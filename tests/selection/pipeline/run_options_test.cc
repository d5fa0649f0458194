// The run's options: one registry for the config file, the report, the flags and the
// shipped default file.
#include "selection/pipeline/run_options.h"

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"
#include "test_files.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

std::string WriteTemp(const std::string& name, const std::string& content) {
  const fs::path path =
      fs::temp_directory_path() /
      ("ieslam_run_options_test_" + std::to_string(::getpid()) + "_" + name + ".yaml");
  std::ofstream(path) << content;
  return path.string();
}

std::string ErrorOf(const std::string& content) {
  RunOptions options;
  try {
    ApplyConfigFile(WriteTemp("bad", content), &options);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// data/config/default.yaml is what `ieslam options` prints: regenerate it with
// `build/apps/ieslam options > data/config/default.yaml` after adding or changing an option.
TEST(RunOptionsTest, TheShippedDefaultFileIsWhatTheRegistryWrites) {
  const std::string shipped =
      testing_files::ReadFile(std::string(IESLAM_SOURCE_DIR) + "/data/config/default.yaml");
  EXPECT_EQ(shipped, ConfigYaml(RunOptions()));
  RunOptions from_file;
  ApplyConfigFile(std::string(IESLAM_SOURCE_DIR) + "/data/config/default.yaml", &from_file);
  EXPECT_EQ(from_file.ToJson().Dump(), RunOptions().ToJson().Dump());
}

// Every option is in the config file or, when the run sets it, in the report only; a
// written config reads back to the same options.
TEST(RunOptionsTest, EveryOptionIsSettableOrDerivedAndReadsBack) {
  const Json report = RunOptions().ToJson();
  int settable = 0, derived = 0;
  for (const BoundOption<RunOptions>& option : RunOptions::Registry().options()) {
    const std::string dumped = report.Dump();
    EXPECT_NE(dumped.find("\"" + option.key + "\""), std::string::npos) << option.name();
    (option.settable ? settable : derived) += 1;
  }
  EXPECT_GT(settable, 70);
  EXPECT_EQ(derived, 5);  // two seeds, the prefetch workers, two thread counts
  RunOptions changed;
  changed.pipeline.selector.buffer_size = 5;
  changed.pipeline.filter.cg_tolerance = 1e-6;
  changed.source.frontend.matching.mutual = false;
  changed.pipeline.ba.robust_loss = BaRobustLoss::kHuber;
  changed.dataset_options.format = "tum";
  changed.threads = 1;
  changed.pipeline.refine = true;
  RunOptions read;
  ApplyConfigFile(WriteTemp("round_trip", ConfigYaml(changed)), &read);
  EXPECT_EQ(read.ToJson().Dump(), changed.ToJson().Dump());
}

TEST(RunOptionsTest, ValuesOverrideDefaults) {
  RunOptions options;
  ApplyConfigFile(WriteTemp("ok",
                            "%YAML:1.0\nselector: { kind: \"all\", buffer: 5 }\n"
                            "features: { image_scale: 1.0 }\n"
                            "registration: { inlier_chi2: 11.34, use_point_covariances: 1 }\n"
                            "filter: { iterative_recovery: 0, max_dense_pose_dim: 0 }\n"
                            "threads: 1\nrefine: 1\n"),
                  &options);
  EXPECT_EQ(options.pipeline.selector.kind, SelectorKind::kAll);
  EXPECT_EQ(options.pipeline.selector.buffer_size, 5);
  EXPECT_EQ(options.source.frontend.features.image_scale, 1.0);
  EXPECT_EQ(options.source.frontend.features.max_features, FeatureOptions().max_features);
  EXPECT_EQ(options.source.frontend.registration.inlier_chi2, 11.34);
  EXPECT_TRUE(options.source.frontend.registration.use_point_covariances);
  EXPECT_FALSE(options.pipeline.filter.iterative_recovery);
  EXPECT_EQ(options.pipeline.filter.max_dense_pose_dim, 0);
  EXPECT_EQ(options.pipeline.filter.cg_tolerance, InformationFilterOptions().cg_tolerance);
  EXPECT_EQ(options.threads, 1);
  EXPECT_TRUE(options.pipeline.refine);
  // The report shows the options used, and the seed and threads as the run sets them.
  options.seed = 9;
  const std::string json = options.ToJson().Dump();
  EXPECT_NE(json.find("\"iterative_recovery\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"max_dense_pose_dim\": 0"), std::string::npos) << json;
  EXPECT_EQ(options.Resolved().source.frontend.registration.seed, 9u);
  EXPECT_EQ(options.Resolved().source.database.seed, 9u);
  EXPECT_EQ(options.Resolved().source.prefetch.workers, 0);
  EXPECT_EQ(options.Resolved().pipeline.ba.num_threads, 1);
}

TEST(RunOptionsTest, BadFilesNameTheKey) {
  EXPECT_NE(ErrorOf("%YAML:1.0\nselector: { buffr: 3 }\n").find("selector.buffr"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nselektor: { buffer: 3 }\n").find("selektor"), std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nselector: { buffer: \"three\" }\n").find("selector.buffer"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nselector: { buffer: -4 }\n").find("-4"), std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nselector: { kind: \"greedy\" }\n").find("selector.kind"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nmap: { voxel_size_m: .nan }\n").find("map"), std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nfilter: { cg_tolerance: 0 }\n").find("cg_tolerance"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nfilter: { iterative_recovery: 2 }\n").find("iterative_recovery"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nfilter: { max_dense_pose_dim: 3 }\n").find("max_dense_pose_dim"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\ndepth_alignment: { min_overlap: 0 }\n").find("min_overlap"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\ndepth_alignment: { grid_step: 0 }\n").find("step"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nregistration: { seed: 3 }\n").find("registration.seed"),
            std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\nselector: { kind: \"deadreckoning\" }\nrefine: 1\n")
                .find("--refine needs a filter"),
            std::string::npos);
  RunOptions options;
  // A missing config file is bad usage (exit 2), like a bad value in one.
  EXPECT_THROW(ApplyConfigFile("/no/such/config.yaml", &options), ConfigError);
}

// OpenCV's YAML parser never returns on this text (core/yaml_text.h); the file is refused first.
TEST(RunOptionsTest, IndentedRootIsRefusedBeforeOpenCvSeesIt) {
  EXPECT_NE(ErrorOf("  selector: { buffer: 3 }\nabc-1\nz: 1\n").find(".yaml:1: expected a key"),
            std::string::npos);
}

}  // namespace
}  // namespace ieslam
