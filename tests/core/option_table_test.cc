#include "core/option_table.h"

#include <gtest/gtest.h>

#include "core/error.h"

namespace ieslam {
namespace {

enum class Colour { kRed, kGreen };
bool ParseColour(const std::string& name, Colour* colour) {
  if (name == "red")
    *colour = Colour::kRed;
  else if (name == "green")
    *colour = Colour::kGreen;
  else
    return false;
  return true;
}
std::string ColourName(Colour colour) { return colour == Colour::kRed ? "red" : "green"; }

struct ToyOptions {
  int count = 3;
  double gate = 0.5;
  double low = 0.1, high = 0.2;
  bool enabled = true;
  uint32_t seed = 7;
  std::string name = "toy";
  Colour colour = Colour::kGreen;

  static const OptionTable<ToyOptions>& Table() {
    static const OptionTable<ToyOptions>* table = [] {
      auto* t = new OptionTable<ToyOptions>;
      t->Int("count", &ToyOptions::count, "how many").Range(1, 10);
      t->Double("gate", &ToyOptions::gate, "a gate").Above(0.0);
      t->Double("low", &ToyOptions::low, "lower bound").Min(0.0);
      t->Double("high", &ToyOptions::high, "upper bound");
      t->Bool("enabled", &ToyOptions::enabled, "on or off");
      t->Uint("seed", &ToyOptions::seed, "set by the caller").Derived();
      t->String("name", &ToyOptions::name, "a name");
      t->Enum("colour", &ToyOptions::colour, ParseColour, ColourName, "red|green", "a colour");
      t->Require([](const ToyOptions& o) {
        return o.low <= o.high ? std::string() : "low must be <= high";
      });
      return t;
    }();
    return *table;
  }
};

std::string ReasonOf(const std::string& key, const OptionText& value) {
  ToyOptions options;
  try {
    ToyOptions::Table().Find(key)->set(value, &options);
  } catch (const ConfigError& e) {
    return e.what();
  }
  const std::string reason = ToyOptions::Table().Find(key)->Check(options);
  return reason.empty() ? "ok" : reason;
}

TEST(OptionTableTest, DefaultsPassAndReportInRegistrationOrder) {
  std::string why;
  EXPECT_TRUE(ToyOptions::Table().Check(ToyOptions(), &why)) << why;
  EXPECT_EQ(ToyOptions::Table().ToJson(ToyOptions()).Dump(0),
            "{\"count\":3,\"gate\":0.5,\"low\":0.1,\"high\":0.2,\"enabled\":true,\"seed\":7,"
            "\"name\":\"toy\",\"colour\":\"green\"}");
  EXPECT_FALSE(ToyOptions::Table().Find("seed")->settable);
  EXPECT_TRUE(ToyOptions::Table().Find("count")->settable);
  EXPECT_EQ(ToyOptions::Table().Find("nope"), nullptr);
}

TEST(OptionTableTest, ValuesAreParsedAndChecked) {
  EXPECT_EQ(ReasonOf("count", {"4"}), "ok");
  EXPECT_EQ(ReasonOf("count", {"11"}), "must be in [1, 10], got 11");
  EXPECT_EQ(ReasonOf("count", {"0"}), "must be in [1, 10], got 0");
  EXPECT_EQ(ReasonOf("count", {"2.5"}), "must be an integer, got '2.5'");
  EXPECT_EQ(ReasonOf("count", {"3", true}), "must be an integer, got the string '3'");
  // An integer too large for its type is refused, not wrapped.
  EXPECT_EQ(ReasonOf("count", {"4294967306"}),
            "must be in [-2147483648, 2147483647], got 4294967306");
  EXPECT_EQ(ReasonOf("gate", {"0"}), "must be > 0.0, got 0.0");
  EXPECT_EQ(ReasonOf("gate", {"1e-3"}), "ok");
  EXPECT_EQ(ReasonOf("gate", {"nan"}), "must be finite, got nan");
  EXPECT_EQ(ReasonOf("gate", {"x"}), "must be a number, got 'x'");
  EXPECT_EQ(ReasonOf("enabled", {"2"}), "must be in [0, 1], got 2");
  EXPECT_EQ(ReasonOf("colour", {"blue", true}), "must be one of red|green, got 'blue'");
  EXPECT_EQ(ReasonOf("colour", {"red", true}), "ok");
}

TEST(OptionTableTest, CheckNamesTheKeyAndRunsTheCrossChecks) {
  ToyOptions options;
  options.count = 20;
  std::string why;
  EXPECT_FALSE(ToyOptions::Table().Check(options, &why));
  EXPECT_EQ(why, "count must be in [1, 10], got 20");
  options = ToyOptions();
  options.low = 0.3;
  EXPECT_FALSE(ToyOptions::Table().Check(options, &why));
  EXPECT_EQ(why, "low must be <= high");
}

TEST(OptionTableTest, RealsFormatToReadBack) {
  EXPECT_EQ(FormatOptionReal(2.0), "2.0");
  EXPECT_EQ(FormatOptionReal(16.27), "16.27");
  EXPECT_EQ(FormatOptionReal(1e10), "1e+10");
  EXPECT_EQ(FormatOptionReal(1e-3), "0.001");
  for (const double value : {2.0, 16.27, 1e10, 1e-3, 0.1 + 0.2}) {
    EXPECT_EQ(ParseOptionReal({FormatOptionReal(value)}), value);
  }
}

}  // namespace
}  // namespace ieslam
