#pragma once

#include <cstdint>

#include "src/core/camera.h"

namespace pano4d {

// How well Project inverts Unproject over an image: a (steps_x + 1) x
// (steps_y + 1) grid of pixel positions spanning the image edge to edge, the
// four corners (0, 0) and (width, height) included. A sample fails when
// Unproject reports a status other than kOk, or when projecting its ray does
// not give a pixel back.
struct RoundTripStats {
  std::int64_t samples = 0;
  std::int64_t failures = 0;
  double max_error_px = 0.0;  // over the samples that did not fail
  double mean_iterations = 0.0;
};

RoundTripStats MeasureRoundTrip(const Camera& camera, int steps_x, int steps_y);

}  // namespace pano4d
