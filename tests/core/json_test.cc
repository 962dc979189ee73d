#include "src/core/json.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(JsonTest, SyntaxErrorNamesSourceAndPosition) {
  const std::string message =
      MessageOf([] { ParseJson("{\"a\": 1,", "scene.json"); });
  EXPECT_EQ(
      message.rfind(
          "scene.json: not valid JSON (parse error at line 1, column 9", 0),
      0u)
      << message;
}

TEST(JsonTest, NumberOverflowIsAnErrorNamingTheSource) {
  // nlohmann reports this as out_of_range, not parse_error (found by fuzzing).
  const std::string message =
      MessageOf([] { ParseJson("{\"f\": 1e999}", "cam.json"); });
  EXPECT_EQ(message.rfind("cam.json: not valid JSON (number overflow", 0), 0u)
      << message;
}

TEST(JsonTest, TypedFieldsAreStrict) {
  const Json j = ParseJson(
      R"({"w": 640, "f": 1.5, "s": "640", "b": true, "big": 1e12, "v": [1, 2.5], "bad": [1, "x"]})",
      "cam.json");
  EXPECT_EQ(GetJson<int>(j, "w", "cam.json"), 640);
  EXPECT_EQ(GetJson<double>(j, "w", "cam.json"), 640.0);
  EXPECT_EQ(GetJson<double>(j, "f", "cam.json"), 1.5);
  EXPECT_EQ(GetJson<std::string>(j, "s", "cam.json"), "640");
  EXPECT_TRUE(GetJson<bool>(j, "b", "cam.json"));
  EXPECT_EQ(GetJson<std::vector<double>>(j, "v", "cam.json"),
            (std::vector<double>{1, 2.5}));

  EXPECT_EQ(MessageOf([&] { GetJson<int>(j, "s", "cam.json"); }),
            "cam.json: field 's' = \"640\": expected an integer, got a string");
  EXPECT_EQ(MessageOf([&] { GetJson<int>(j, "f", "cam.json"); }),
            "cam.json: field 'f' = 1.5: expected an integer, got a number");
  EXPECT_EQ(MessageOf([&] { GetJson<int>(j, "missing", "cam.json"); }),
            "cam.json: field 'missing': missing");
  EXPECT_EQ(
      MessageOf([&] { GetJson<std::vector<double>>(j, "bad", "cam.json"); }),
      "cam.json: field 'bad[1]' = \"x\": expected a number");
  EXPECT_EQ(MessageOf([&] { GetJson<bool>(j, "w", "cam.json"); }),
            "cam.json: field 'w' = 640: expected true or false, got a number");
  EXPECT_NE(MessageOf([&] { GetJson<int>(j, "big", "cam.json"); }), "no error");
  EXPECT_NE(MessageOf([&] { GetJson<int>(Json::array(), "w", "cam.json"); }),
            "no error");
}

TEST(JsonTest, OptionalFieldsFallBackOnlyWhenAbsent) {
  const Json j = ParseJson(R"({"n": "three"})", "opts.json");
  EXPECT_EQ(GetJsonOr<int>(j, "m", 7, "opts.json"), 7);
  EXPECT_THROW(GetJsonOr<int>(j, "n", 7, "opts.json"), Error);
}

// What resume checks use to name the option that changed.
TEST(JsonTest, FirstDifferenceNamesTheKeyPath) {
  const Json a = {{"seed", 0}, {"init", {{"num_bases", 20}, {"sh", 0}}}};
  EXPECT_FALSE(FirstDifference(a, a));
  Json b = a;
  b["init"]["num_bases"] = 10;
  b["seed"] = 3;  // "init" sorts before "seed": the first difference
  const std::optional<JsonDifference> d = FirstDifference(a, b);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->path, "init.num_bases");
  EXPECT_EQ(d->first, 20);
  EXPECT_EQ(d->second, 10);
  Json c = a;
  c.erase("seed");
  const std::optional<JsonDifference> missing = FirstDifference(a, c);
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->path, "seed");
  EXPECT_TRUE(missing->second.is_null());
  const std::optional<JsonDifference> whole =
      FirstDifference(Json(1), Json("1"));
  ASSERT_TRUE(whole);
  EXPECT_EQ(whole->path, "");
}

TEST(JsonTest, FileRoundTrip) {
  testing::TempDir dir;
  const Json value{{"psnr", 31.5}, {"lpips", nullptr}, {"frames", {1, 2, 3}}};
  WriteJson(dir / "metrics" / "m.json", value);
  EXPECT_EQ(ReadJson(dir / "metrics" / "m.json"), value);
  EXPECT_THROW(ReadJson(dir / "nope.json"), Error);
}

}  // namespace
}  // namespace pano4d
