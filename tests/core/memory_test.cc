#include "src/core/memory.h"

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

// Work larger than the machine is refused up front, with the figure and
// what it was for; work that fits passes.
TEST(MemoryTest, WorkLargerThanTheMachineIsRefusedWithTheFigure) {
  ASSERT_TRUE(AvailableMemoryBytes().has_value()) << "no /proc/meminfo";
  EXPECT_GT(*AvailableMemoryBytes(), 0u);
  EXPECT_NO_THROW(CheckMemoryFits(1024.0, "render", "one small frame"));
  try {
    CheckMemoryFits(1e18, "render", "2147483647 frames of 640x480");
    FAIL() << "an exabyte was taken to fit";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("render"), std::string::npos) << what;
    EXPECT_NE(what.find("2147483647 frames"), std::string::npos) << what;
    EXPECT_NE(what.find("GiB is available"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace pano4d
