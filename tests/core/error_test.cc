#include "src/core/error.h"

#include <gtest/gtest.h>

namespace pano4d {
namespace {

TEST(ErrorTest, OneLineNamingSourceFieldValueAndProblem) {
  const Error e("scene/cam.json", "width", "\"640\"", "expected an integer");
  EXPECT_STREQ(e.what(),
               "scene/cam.json: field 'width' = \"640\": expected an integer");
  EXPECT_EQ(e.source(), "scene/cam.json");
  EXPECT_EQ(e.field(), "width");
  EXPECT_EQ(e.value(), "\"640\"");
  EXPECT_EQ(e.problem(), "expected an integer");
}

TEST(ErrorTest, EmptyPartsAreLeftOut) {
  EXPECT_STREQ(Error::In("a.png", "does not exist").what(),
               "a.png: does not exist");
  EXPECT_STREQ(Error("", "", "", "bad").what(), "pano4d: bad");
  EXPECT_STREQ(Error("opts", "", "7", "too big").what(), "opts: 7: too big");
}

TEST(ErrorTest, NewlinesNeverSplitTheLine) {
  const Error e("f.txt", "", "", "line one\nline two");
  EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
}

}  // namespace
}  // namespace pano4d
