#include "src/core/strings.h"

#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace pano4d {
namespace {

TEST(StringsTest, NaturalLessOrdersNumberedFramesByTheirNumber) {
  std::vector<std::string> names = {"f10.png",  "f2.png",  "f1.png",
                                    "f100.png", "f11.png", "g0.png"};
  std::sort(names.begin(), names.end(), NaturalLess);
  EXPECT_EQ(names, (std::vector<std::string>{"f1.png", "f2.png", "f10.png",
                                             "f11.png", "f100.png", "g0.png"}));
  // Zero-padded names keep their byte order.
  EXPECT_TRUE(NaturalLess("frame_000009", "frame_000010"));
  EXPECT_FALSE(NaturalLess("frame_000010", "frame_000009"));
  // Same value, other padding: a strict order all the same.
  EXPECT_NE(NaturalLess("7", "007"), NaturalLess("007", "7"));
  EXPECT_FALSE(NaturalLess("a", "a"));
  EXPECT_TRUE(NaturalLess("a", "a1"));
  EXPECT_TRUE(
      NaturalLess("99999999999999999999998", "99999999999999999999999"));
}

}  // namespace
}  // namespace pano4d
