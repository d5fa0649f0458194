#include "apps/flags.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

const std::vector<FlagSpec> kSpecs = {{"dataset", "DIR", "dataset"},
                                      {"buffer", "N", "buffer"},
                                      {"refine", "", "refine"},
                                      {"max-diff", "S", "max diff"},
                                      {"buffers", "LIST", "buffers"}};

std::string ErrorOf(const std::vector<std::string>& args, const char* flag = nullptr) {
  try {
    const Flags flags(args, kSpecs);
    if (flag != nullptr) flags.GetInt(flag, 0, 1, 20);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(FlagsTest, ParsesValuesBooleansAndInlineValues) {
  const Flags flags({"--dataset", "/d", "--refine", "--buffer=4", "--max-diff", "0.05"}, kSpecs);
  EXPECT_EQ(flags.GetString("dataset"), "/d");
  EXPECT_TRUE(flags.Has("refine"));
  EXPECT_EQ(flags.GetInt("buffer", 3, 1, 20), 4);
  EXPECT_EQ(flags.GetString("max-diff"), "0.05");
  EXPECT_EQ(flags.GetInt("missing-but-defaulted", 7, 0, 10), 7);
  EXPECT_FALSE(flags.help());
  EXPECT_TRUE(Flags({"--help"}, kSpecs).help());
}

TEST(FlagsTest, BadInputNamesTheFlagAndValue) {
  EXPECT_NE(ErrorOf({"--bogus"}).find("--bogus"), std::string::npos);
  EXPECT_NE(ErrorOf({"--dataset"}).find("needs a value"), std::string::npos);
  EXPECT_NE(ErrorOf({"--buffer", "-4"}, "buffer").find("-4"), std::string::npos);
  EXPECT_NE(ErrorOf({"--buffer", "three"}, "buffer").find("three"), std::string::npos);
  EXPECT_NE(ErrorOf({"--refine=1"}).find("takes no value"), std::string::npos);
  EXPECT_NE(ErrorOf({"--buffer", "2", "--buffer", "3"}).find("twice"), std::string::npos);
  EXPECT_NE(ErrorOf({"stray"}).find("stray"), std::string::npos);
  EXPECT_THROW(Flags({}, kSpecs).Require("dataset"), ConfigError);
}

TEST(FlagsTest, IntegerLists) {
  const Flags flags({"--buffers", "2,3,4,5"}, kSpecs);
  EXPECT_EQ(flags.GetIntList("buffers", {}, 1, 20), std::vector<int>({2, 3, 4, 5}));
  EXPECT_THROW(Flags({"--buffers", "2,x"}, kSpecs).GetIntList("buffers", {}, 1, 20), ConfigError);
  EXPECT_THROW(Flags({"--buffers", "2,99"}, kSpecs).GetIntList("buffers", {}, 1, 20), ConfigError);
}

TEST(FlagsTest, DoubleListsHaveTheirSizeAndRange) {
  const Flags flags({"--buffers", "-0.02,0.003,4e-3"}, kSpecs);
  EXPECT_EQ(flags.GetDoubleList("buffers", {}, 3, -0.5, 0.5),
            std::vector<double>({-0.02, 0.003, 0.004}));
  EXPECT_EQ(Flags({}, kSpecs).GetDoubleList("buffers", {1.0, 2.0}, 2, 0.0, 3.0),
            std::vector<double>({1.0, 2.0}));
  for (const char* bad : {"0.1,0.2", "0.1,0.2,0.3,0.4", "0.1,x,0.3", "0.1,0.9,0.3", "0.1,nan,0"}) {
    try {
      Flags({"--buffers", bad}, kSpecs).GetDoubleList("buffers", {}, 3, -0.5, 0.5);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("--buffers"), std::string::npos) << e.what();
    }
  }
}

TEST(FlagsTest, HelpListsEveryFlag) {
  const std::string help = FormatHelp("run", "--dataset DIR", "Runs.", kSpecs);
  for (const FlagSpec& spec : kSpecs) EXPECT_NE(help.find("--" + spec.name), std::string::npos);
}

}  // namespace
}  // namespace ieslam
