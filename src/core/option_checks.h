#pragma once

// The range checks of the options structs' Check(): each throws an Error
// naming the options (`source`, e.g. "fit options"), the field and the
// value, and refuses NaN and Inf, which pass every comparison. (The CLI's
// flags have their own validators in src/cli/options.h, which check the
// text a user typed before it reaches these structs.)

#include <string>

namespace pano4d {

// value > 0: "must be positive"
void CheckPositive(double value, const std::string& source,
                   const std::string& field);
// value >= 0: "must be zero or positive"
void CheckNonNegative(double value, const std::string& source,
                      const std::string& field);

}  // namespace pano4d
