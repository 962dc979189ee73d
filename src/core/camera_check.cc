#include "src/core/camera_check.h"

#include <algorithm>

namespace pano4d {

RoundTripStats MeasureRoundTrip(const Camera& camera, int steps_x,
                                int steps_y) {
  RoundTripStats stats;
  std::int64_t iterations = 0;
  for (int j = 0; j <= steps_y; ++j) {
    for (int i = 0; i <= steps_x; ++i) {
      const Eigen::Vector2d pixel(
          camera.width * static_cast<double>(i) / steps_x,
          camera.height * static_cast<double>(j) / steps_y);
      ++stats.samples;
      const UnprojectResult ray = camera.Unproject(pixel);
      const std::optional<Eigen::Vector2d> back =
          ray.ok() ? camera.Project(ray.ray) : std::nullopt;
      if (!back) {
        ++stats.failures;
        continue;
      }
      iterations += ray.iterations;
      stats.max_error_px = std::max(stats.max_error_px, (*back - pixel).norm());
    }
  }
  const std::int64_t ok = stats.samples - stats.failures;
  stats.mean_iterations = ok > 0 ? static_cast<double>(iterations) / ok : 0.0;
  return stats;
}

}  // namespace pano4d
