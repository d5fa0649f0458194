#include "core/option_registry.h"

#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

namespace fs = std::filesystem;

struct Inner {
  int steps = 4;
  double scale = 0.5;
  static const OptionTable<Inner>& Table() {
    static const OptionTable<Inner>* table = [] {
      auto* t = new OptionTable<Inner>;
      t->Int("steps", &Inner::steps, "steps per thing").Min(1);
      t->Double("scale", &Inner::scale, "a scale").Above(0.0);
      return t;
    }();
    return *table;
  }
};

struct Extra {
  int grid = 2;
  static const OptionTable<Extra>& Table() {
    static const OptionTable<Extra>* table = [] {
      auto* t = new OptionTable<Extra>;
      t->Int("grid", &Extra::grid, "grid step").Min(1);
      return t;
    }();
    return *table;
  }
};

struct Top {
  int threads = 0;
  uint32_t seed = 1;
  static const OptionTable<Top>& Table() {
    static const OptionTable<Top>* table = [] {
      auto* t = new OptionTable<Top>;
      t->Int("threads", &Top::threads, "threads").Range(0, 256);
      t->Uint("seed", &Top::seed, "the run's seed").Derived();
      return t;
    }();
    return *table;
  }
};

struct Root {
  Inner first, second;
  Extra extra;
  Top top;
};

const OptionRegistry<Root>& Registry() {
  static const OptionRegistry<Root>* registry = [] {
    auto* r = new OptionRegistry<Root>;
    r->Section<Inner>("first", Inner::Table(), [](Root* root) { return &root->first; });
    r->Section<Inner>("second", Inner::Table(), [](Root* root) { return &root->second; });
    r->Section<Extra>("second", Extra::Table(), [](Root* root) { return &root->extra; });
    r->Section<Top>("", Top::Table(), [](Root* root) { return &root->top; });
    return r;
  }();
  return *registry;
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const fs::path path =
      fs::temp_directory_path() /
      ("ieslam_option_registry_" + std::to_string(::getpid()) + "_" + name + ".yaml");
  std::ofstream(path) << text;
  return path.string();
}

std::string ErrorOf(const std::string& text) {
  Root root;
  try {
    Registry().ApplyYaml(WriteTemp("bad", text), &root);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(OptionRegistryTest, SectionsBindTablesToTheRoot) {
  Root root;
  Registry().ApplyYaml(WriteTemp("ok", "second: { steps: 9, grid: 3 }\nthreads: 2\n"), &root);
  EXPECT_EQ(root.first.steps, 4);
  EXPECT_EQ(root.second.steps, 9);
  EXPECT_EQ(root.extra.grid, 3);
  EXPECT_EQ(root.top.threads, 2);
  EXPECT_EQ(Registry().ToJson(root).Dump(0),
            "{\"first\":{\"steps\":4,\"scale\":0.5},\"second\":{\"steps\":9,\"scale\":0.5,"
            "\"grid\":3},\"threads\":2,\"seed\":1}");
  Registry().Set(&root, "first.scale", {"2"}, "--scale");
  EXPECT_EQ(root.first.scale, 2.0);
}

TEST(OptionRegistryTest, TheWrittenConfigReadsBackAsTheDefaults) {
  Root changed;
  changed.first.steps = 7;
  changed.top.threads = 5;
  changed.second.scale = 1e10;  // written 1e+10, which must read back as a real
  const std::string yaml = Registry().ToYaml(changed, "# header\n");
  EXPECT_EQ(yaml.rfind("%YAML:1.0\n---\n# header\nfirst:\n  steps: 7", 0), 0u) << yaml;
  EXPECT_NE(yaml.find("# steps per thing"), std::string::npos) << yaml;
  EXPECT_EQ(yaml.find("seed"), std::string::npos) << yaml;  // derived: not in the file
  Root read;
  Registry().ApplyYaml(WriteTemp("round_trip", yaml), &read);
  EXPECT_EQ(Registry().ToJson(read).Dump(), Registry().ToJson(changed).Dump());
}

TEST(OptionRegistryTest, BadFilesAndValuesNameTheFileAndTheOption) {
  EXPECT_NE(ErrorOf("first: { stepz: 3 }\n").find("first.stepz is not a known option"),
            std::string::npos);
  EXPECT_NE(ErrorOf("third: { steps: 3 }\n").find("unknown section 'third'"), std::string::npos);
  EXPECT_NE(ErrorOf("first: { steps: 0 }\n").find("first.steps must be >= 1, got 0"),
            std::string::npos);
  EXPECT_NE(ErrorOf("first: { steps: \"three\" }\n").find("first.steps must be an integer"),
            std::string::npos);
  // OpenCV alone would read 4294967306 as 10.
  EXPECT_NE(ErrorOf("first: { steps: 4294967306 }\n")
                .find("first.steps must be in [-2147483648, 2147483647], got 4294967306"),
            std::string::npos)
      << ErrorOf("first: { steps: 4294967306 }\n");
  EXPECT_NE(ErrorOf("seed: 4\n").find("seed is not set directly"), std::string::npos);
  EXPECT_NE(ErrorOf("first: { steps: [1, 2] }\n").find("first.steps must be a number or a string"),
            std::string::npos);
  EXPECT_EQ(ErrorOf("first: { steps: 3 }\n"), "");
  Root root;
  EXPECT_THROW(Registry().ApplyYaml("/no/such/config.yaml", &root), ConfigError);
  try {
    Registry().Set(&root, "threads", {"300"}, "--threads");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "--threads: threads must be in [0, 256], got 300");
  }
}

}  // namespace
}  // namespace ieslam
