#include "src/core/option_checks.h"

#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

std::string ErrorOf(void (*check)(double, const std::string&,
                                  const std::string&),
                    double value) {
  try {
    check(value, "fit options", "depth_weight");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// NaN and Inf are refused although they pass (or fail) every comparison;
// the message names the options, the field and the value as written.
TEST(OptionChecksTest, RangesRefuseNanAndInfAndNameTheField) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ErrorOf(CheckPositive, 0.5), "");
  EXPECT_EQ(ErrorOf(CheckNonNegative, 0), "");
  EXPECT_EQ(ErrorOf(CheckPositive, 0),
            "fit options: field 'depth_weight' = 0: must be positive");
  EXPECT_EQ(ErrorOf(CheckNonNegative, -2),
            "fit options: field 'depth_weight' = -2: must be zero or positive");
  for (const double bad : {nan, inf}) {
    EXPECT_NE(ErrorOf(CheckPositive, bad), "") << bad;
    EXPECT_NE(ErrorOf(CheckNonNegative, bad), "") << bad;
  }
}

}  // namespace
}  // namespace pano4d
