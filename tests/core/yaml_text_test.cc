#include "core/yaml_text.h"

#include <unistd.h>

#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

// Opens `text` and exits 0 with the ConfigError message on stderr, 1 when it is accepted.
// SIGALRM ends a run that hangs in OpenCV, so a text that slips through fails its test
// instead of stalling the suite.
[[noreturn]] void OpenAndExit(const std::string& text) {
  alarm(10);
  try {
    OpenYamlMap(text, "in.yaml");
  } catch (const ConfigError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    _exit(0);
  }
  _exit(1);
}

// Each text makes Debian's OpenCV 4.6 cv::FileStorage loop forever (checked by hand with
// `timeout`): the root collection ends early and a `-` (not `---`) stands three characters on.
TEST(YamlForOpenCvDeathTest, TextsOpenCvHangsOnAreRefusedNamingFileAndLine) {
  struct Case {
    const char* text;
    const char* message;  // a regular expression on stderr
  } cases[] = {
      {"  a: 1\nabc-1\nz: 1\n", "in.yaml:1: expected a key in column 1"},     // indented root
      {"a: 1\n...\n-x\nz: 1\n", "in.yaml:2: '...' \\(end of document\\)"},    // ended early
      {"--- a: 1\nbcd-x\nz: 1\n", "in.yaml:1: '---' may only stand alone"},   // root on ---
      {"---\n{a: 1}abc-1\nz: 1\n", "in.yaml:2: expected a key in column 1"},  // flow map
      {"---\n[1]\nabc-1\nz: 1\n", "in.yaml:2: expected a key in column 1"},   // flow sequence
      {"%YAML:1.0\n%YAMckage: x\n  depth_kind: radial\n 3, -0.5,\n  0]\n",
       "in.yaml:3: expected a key in column 1"},  // the fuzzer's finding, shortened
  };
  for (const Case& c : cases) {
    EXPECT_EXIT(OpenAndExit(c.text), ::testing::ExitedWithCode(0), c.message) << c.text;
  }
}

TEST(YamlForOpenCv, RefusesSecondDocumentsAndNulBytes) {
  EXPECT_THROW(YamlForOpenCv("a: 1\n---\nb: 2\n", "in.yaml"), ConfigError);
  EXPECT_THROW(YamlForOpenCv("---\n---\na: 1\n", "in.yaml"), ConfigError);
  EXPECT_THROW(YamlForOpenCv("- 1\n- 2\n", "in.yaml"), ConfigError);
  try {
    YamlForOpenCv(std::string("a: 1\nb\0: 2\n", 11), "in.yaml");
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "in.yaml: not a text file (NUL byte at offset 6)");
  }
}

TEST(YamlForOpenCv, KeepsWhatOpenCvWritesAndHandWrittenFiles) {
  // cv::FileStorage's own output: directive, `---`, map.
  const std::string written = "%YAML:1.0\n---\nname: x\nnoise: {a: 1}\nm: [1, 2,\n    3]\n";
  EXPECT_EQ(YamlForOpenCv(written, "in.yaml"), written);
  const std::string hand =
      "# comment\r\n\r\n--- # start\r\n  # indented comment\r\n_k: 1\r\nsub:\r\n  v: 2\r\n";
  EXPECT_EQ(YamlForOpenCv(hand, "in.yaml"), "%YAML:1.0\n" + hand);
  const cv::FileStorage fs = OpenYamlMap(hand, "in.yaml");
  EXPECT_EQ(static_cast<int>(fs["_k"]), 1);
  EXPECT_EQ(static_cast<int>(fs["sub"]["v"]), 2);
  EXPECT_EQ(static_cast<int>(OpenYamlMap(written, "in.yaml")["m"][2]), 3);
}

TEST(YamlForOpenCv, OpenCvErrorsAndNonMapsAreConfigErrorsNamingTheFile) {
  for (const char* text : {"a: [1, 2\n", "a: 1\n  b: 2\n", "abc\n", "# only a comment\n"}) {
    try {
      OpenYamlMap(text, "in.yaml");
      ADD_FAILURE() << "accepted " << text;
    } catch (const ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("in.yaml: not valid YAML", 0), 0u) << e.what();
    }
  }
}

// The message of the ConfigError YamlForOpenCv throws for `text` ("" when it accepts it).
std::string ScreenError(const std::string& text) {
  try {
    YamlForOpenCv(text, "in.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// OpenCV's parser recurses once per level: 50 000 `[` overflowed the stack (exit 139).
TEST(YamlForOpenCv, DeepNestingIsRefusedNamingTheLine) {
  EXPECT_EQ(ScreenError("%YAML:1.0\n---\na: " + std::string(50000, '[')),
            "in.yaml:3: nesting deeper than 64 levels");
  std::string block;  // 70 maps, each indented one more than its parent
  for (int i = 0; i < 70; ++i) block += std::string(i, ' ') + "k" + std::to_string(i) + ":\n";
  EXPECT_EQ(ScreenError(block), "in.yaml:65: nesting deeper than 64 levels");
  std::string entries = "a:\n";  // block sequences nest by their `- ` too
  for (int i = 0; i < 70; ++i) entries += "- ";
  EXPECT_EQ(ScreenError(entries + "1\n"), "in.yaml:2: nesting deeper than 64 levels");
  // 64 levels (the root map and 63 brackets) are accepted, and brackets that close, sit in
  // quoted strings or in comments do not add up.
  const std::string deepest = "a: " + std::string(63, '[') + std::string(63, ']') + "\n";
  EXPECT_EQ(static_cast<int>(OpenYamlMap(deepest, "in.yaml")["a"].size()), 1);
  std::string many = "a: '" + std::string(100, '[') + "'\nb: 1 # " + std::string(100, '{') + "\n";
  for (int i = 0; i < 100; ++i) many += "c" + std::to_string(i) + ": [[1], {x: [2]}]\n";
  EXPECT_EQ(ScreenError(many), "");
  EXPECT_EQ(static_cast<int>(OpenYamlMap(many, "in.yaml")["b"]), 1);
}

TEST(YamlForOpenCv, TextsOverTheSizeBoundAreRefused) {
  const std::string big = "a: 1\n# " + std::string(kMaxYamlBytes, 'x') + "\n";
  EXPECT_EQ(ScreenError(big), "in.yaml: " + std::to_string(big.size()) + " bytes, more than the " +
                                  std::to_string(kMaxYamlBytes) + " a YAML file may hold");
}

// OpenCV casts strtol's long to int: 4294967306 would read as 10, 3000000000 as -1294967296.
TEST(YamlForOpenCv, IntegersOutsideIntReachTheReaderAsRealsNotWrapped) {
  const cv::FileStorage fs = OpenYamlMap(
      "a: 4294967306\nb: -3000000000\nc: [1, 99999999999]\nd: 2147483647\ne: -2147483648\n"
      "f: 0x7fffffff\n",
      "in.yaml");
  EXPECT_TRUE(fs["a"].isReal());
  EXPECT_EQ(static_cast<double>(fs["a"]), 4294967306.0);
  EXPECT_EQ(static_cast<double>(fs["b"]), -3000000000.0);
  EXPECT_TRUE(fs["c"][0].isInt());
  EXPECT_EQ(static_cast<double>(fs["c"][1]), 99999999999.0);
  EXPECT_TRUE(fs["d"].isInt());
  EXPECT_EQ(static_cast<int>(fs["d"]), 2147483647);
  EXPECT_EQ(static_cast<int>(fs["e"]), -2147483648);
  EXPECT_EQ(static_cast<int>(fs["f"]), 0x7fffffff);
  const cv::FileStorage entries =
      OpenYamlMap("a:\n  - 4294967306\n  - [1, {b: 4294967306}]\n", "in.yaml");
  EXPECT_EQ(static_cast<double>(entries["a"][0]), 4294967306.0);
  EXPECT_EQ(static_cast<double>(entries["a"][1][1]["b"]), 4294967306.0);
  // Strings, comments and keys are left as they are.
  const std::string text =
      "s: '4294967306'\nt: x4294967306 # 4294967306\nu: run 4294967306\nv: a[b, 4294967306\n";
  EXPECT_EQ(YamlForOpenCv(text, "in.yaml"), "%YAML:1.0\n" + text);
  // Hexadecimal and octal have no real form to hand over.
  EXPECT_EQ(ScreenError("a: 1\nb: 0x100000000\n"),
            "in.yaml:2: integer 0x100000000 is outside the range of int; write it in decimal");
  EXPECT_NE(ScreenError("b: [077777777777]\n"), "");
}

}  // namespace
}  // namespace ieslam
