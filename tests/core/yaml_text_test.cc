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

}  // namespace
}  // namespace ieslam
