#include "core/json.h"

#include <cmath>

#include <gtest/gtest.h>

namespace ieslam {
namespace {

TEST(JsonTest, ObjectsKeepInsertionOrderAndNest) {
  Json report = Json::Object();
  report.Set("version", "0.1.0").Set("frames", 500).Set("ok", true);
  report["seconds"].Set("total", 1.5).Set("ba", 0.25);
  report.Set("frames", 499);  // replaced in place
  EXPECT_EQ(report.Dump(0),
            R"({"version":"0.1.0","frames":499,"ok":true,"seconds":{"total":1.5,"ba":0.25}})");
}

TEST(JsonTest, NumbersRoundTripAndNonFiniteIsNull) {
  Json values = Json::ArrayOf(std::vector<double>{0.1, 1e-12, 123456.789, std::nan(""), INFINITY});
  EXPECT_EQ(values.Dump(0), "[0.1,1e-12,123456.789,null,null]");
  EXPECT_EQ(std::stod("0.30000000000000004"), 0.1 + 0.2);
  EXPECT_EQ(Json(0.1 + 0.2).Dump(), "0.30000000000000004");
}

TEST(JsonTest, BareDoublesPrintIntegralValuesWithoutAPoint) {
  EXPECT_EQ(Json::BareDouble(1.0).Dump(), "1");
  EXPECT_EQ(Json::BareDouble(0.0).Dump(), "0");
  EXPECT_EQ(Json::BareDouble(0.02).Dump(), "0.02");
  EXPECT_EQ(Json::BareDouble(1e20).Dump(), "1e+20");
  EXPECT_EQ(Json::BareDouble(std::nan("")).Dump(), "null");
  Json object = Json::Object();
  object.Set("bare", Json::BareDouble(2.0)).Set("plain", 2.0);
  EXPECT_EQ(object.Dump(0), R"({"bare":2,"plain":2.0})");
}

TEST(JsonTest, IntegralDoublesReadBackAsDoubles) {
  EXPECT_EQ(Json(3.0).Dump(), "3.0");
  EXPECT_EQ(Json(0.0).Dump(), "0.0");
  EXPECT_EQ(Json(-0.0).Dump(), "-0.0");
  EXPECT_EQ(Json(1e20).Dump(), "1e+20");
  EXPECT_EQ(Json(3).Dump(), "3");  // integers stay integers
  EXPECT_EQ(Json(int64_t{-7}).Dump(), "-7");
}

TEST(JsonTest, EmptyTellsAnObjectOrArrayWithoutContent) {
  EXPECT_TRUE(Json::Object().empty());
  EXPECT_TRUE(Json::Array().empty());
  EXPECT_FALSE(Json::Object().Set("a", 1).empty());
  EXPECT_FALSE(Json::Array().Push(1).empty());
}

TEST(JsonTest, StringsAreEscaped) {
  EXPECT_EQ(Json(std::string("a\"b\\c\nd\x01")).Dump(), R"("a\"b\\c\nd\u0001")");
}

TEST(JsonTest, PrettyPrintsArraysOfObjectsOnePerLine) {
  Json table = Json::Array();
  table.Push(Json::Object().Set("frame", 3).Set("reason", "textureless"));
  Json report = Json::Object()
                    .Set("frames_skipped", table)
                    .Set("band", Json::ArrayOf(std::vector<double>{1, 2}));
  EXPECT_EQ(
      report.Dump(2),
      "{\n  \"frames_skipped\": [\n    {\n      \"frame\": 3,\n      \"reason\": \"textureless\"\n"
      "    }\n  ],\n  \"band\": [1.0, 2.0]\n}");
}

}  // namespace
}  // namespace ieslam
