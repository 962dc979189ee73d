#include "src/core/check.h"

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

// A failed invariant reads as pano4d's bug, with the file, line and the
// condition, and is not an input Error (which tells a user to change
// something).
TEST(CheckTest, AFailedInvariantSaysItIsABugWithFileAndLine) {
  EXPECT_NO_THROW(PANO4D_CHECK(2 + 2 == 4, "arithmetic"));
  const int line = __LINE__ + 2;
  try {
    PANO4D_CHECK(2 + 2 == 5, "sizes drifted apart");
    FAIL() << "a false condition passed";
  } catch (const Error&) {
    FAIL() << "an internal check threw an input Error";
  } catch (const InternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("a bug in pano4d"), std::string::npos) << what;
    EXPECT_NE(what.find("sizes drifted apart"), std::string::npos) << what;
    EXPECT_NE(what.find("check_test.cc:" + std::to_string(line)),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("2 + 2 == 5"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace pano4d
