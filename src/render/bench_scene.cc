#include "src/render/bench_scene.h"

#include <cmath>
#include <random>

#include "src/render/sh.h"

namespace pano4d {

RasterCamera BenchCamera(int width, int height) {
  RasterCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = 0.9f * width;
  c.cx = width / 2.0f;
  c.cy = height / 2.0f;
  return c;
}

GaussianModel RandomViewFillingScene(std::size_t count,
                                     const RasterCamera& camera,
                                     float radius_px, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0, 1);
  GaussianModel m;
  m.sh_degree = 0;
  m.Resize(count);
  // 3 sqrt(lambda) = radius with lambda = (f sigma / z)^2 + low-pass 0.3.
  const float sigma_px =
      std::sqrt(std::max(0.01f, radius_px * radius_px / 9.0f - 0.3f));
  for (std::size_t i = 0; i < count; ++i) {
    const float z = 2.0f + 2.0f * unit(rng);
    const float u = unit(rng) * camera.width, v = unit(rng) * camera.height;
    const Eigen::Vector3f mean = camera.CameraPoint(u, v, z);
    for (int k = 0; k < 3; ++k) m.means[3 * i + k] = mean[k];
    const float log_scale = std::log(sigma_px * z / camera.fx);
    for (int k = 0; k < 3; ++k) {
      m.log_scales[3 * i + k] = log_scale;
      m.sh[3 * i + k] = (unit(rng) - 0.5f) / static_cast<float>(kShC0);
    }
    m.quats[4 * i] = 1;
    m.quats[4 * i + 1] = m.quats[4 * i + 2] = m.quats[4 * i + 3] = 0;
    m.opacities[i] = 0.0f;  // sigmoid(0) = 0.5
  }
  return m;
}

}  // namespace pano4d
