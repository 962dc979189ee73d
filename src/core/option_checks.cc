#include "src/core/option_checks.h"

#include <cmath>

#include "src/core/error.h"
#include "src/core/strings.h"

namespace pano4d {

void CheckPositive(double value, const std::string& source,
                   const std::string& field) {
  if (!(value > 0) || !std::isfinite(value))
    throw Error(source, field, StringPrintf("%g", value), "must be positive");
}

void CheckNonNegative(double value, const std::string& source,
                      const std::string& field) {
  if (!(value >= 0) || !std::isfinite(value)) {
    throw Error(source, field, StringPrintf("%g", value),
                "must be zero or positive");
  }
}

}  // namespace pano4d
