#include "apps/config_file.h"

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

std::string WriteTemp(const std::string& name, const std::string& content) {
  const fs::path path = fs::temp_directory_path() / ("ieslam_config_test_" + name + ".yaml");
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

TEST(ConfigFileTest, TheShippedDefaultFileHoldsTheDefaults) {
  RunOptions from_file;
  ApplyConfigFile(std::string(IESLAM_SOURCE_DIR) + "/data/config/default.yaml", &from_file);
  EXPECT_EQ(from_file.ToJson().Dump(), RunOptions().ToJson().Dump());
}

TEST(ConfigFileTest, ValuesOverrideDefaults) {
  RunOptions options;
  ApplyConfigFile(WriteTemp("ok",
                            "%YAML:1.0\nselector: { kind: \"all\", buffer: 5 }\n"
                            "features: { image_scale: 1.0 }\n"
                            "registration: { inlier_chi2: 11.34, use_point_covariances: 1 }\n"
                            "filter: { iterative_recovery: 0, max_dense_pose_dim: 0 }\n"),
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
  // The report shows the filter options used.
  const std::string json = options.ToJson().Dump();
  EXPECT_NE(json.find("\"iterative_recovery\": false"), std::string::npos) << json;
  EXPECT_NE(json.find("\"max_dense_pose_dim\": 0"), std::string::npos) << json;
}

TEST(ConfigFileTest, BadFilesNameTheKey) {
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
  RunOptions options;
  // A missing config file is bad usage (exit 2), like a bad value in one.
  EXPECT_THROW(ApplyConfigFile("/no/such/config.yaml", &options), ConfigError);
}

// OpenCV's YAML parser never returns on this text (core/yaml_text.h); the file is refused first.
TEST(ConfigFileTest, IndentedRootIsRefusedBeforeOpenCvSeesIt) {
  EXPECT_NE(ErrorOf("  selector: { buffer: 3 }\nabc-1\nz: 1\n").find(".yaml:1: expected a key"),
            std::string::npos);
}

}  // namespace
}  // namespace ieslam
