#include "src/render/gaussians.h"

#include <cmath>
#include <string>

#include "src/core/error.h"

namespace pano4d {

template <typename T>
void GaussianModelT<T>::Resize(std::size_t n) {
  means.resize(3 * n);
  log_scales.resize(3 * n);
  quats.resize(4 * n);
  opacities.resize(n);
  sh.resize(n * sh_coefficients() * 3);
}

template <typename T>
void GaussianModelT<T>::Check() const {
  if (sh_degree < 0 || sh_degree > 3) {
    throw Error("gaussians", "sh_degree", std::to_string(sh_degree),
                "must be 0..3");
  }
  const std::size_t n = size();
  const auto expect = [&](const std::vector<T>& v, std::size_t per,
                          const char* name) {
    if (v.size() != n * per) {
      throw Error("gaussians", name, std::to_string(v.size()) + " values",
                  "expected " + std::to_string(n * per) + " for " +
                      std::to_string(n) + " Gaussians");
    }
  };
  expect(means, 3, "means");
  expect(log_scales, 3, "log_scales");
  expect(quats, 4, "quats");
  expect(sh, static_cast<std::size_t>(sh_coefficients()) * 3, "sh");
  expect(opacities, 1, "opacities");
}

template <typename T>
void GaussianModelT<T>::CheckValues() const {
  Check();
  const std::size_t n = size();
  // Every value finite, every rotation a quaternion that is not zero (it
  // has no direction to normalise to): a file that breaks either is
  // corrupt, and would reach a PLY or a render as NaN.
  const auto finite = [&](const std::vector<T>& v, const char* name) {
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v[i])) {
        throw Error("gaussians",
                    std::string(name) + "[" + std::to_string(i) + "]",
                    std::to_string(v[i]), "not finite");
      }
    }
  };
  finite(means, "means");
  finite(log_scales, "log_scales");
  finite(quats, "quats");
  finite(opacities, "opacities");
  finite(sh, "sh");
  for (std::size_t i = 0; i < n; ++i) {
    const T* q = &quats[4 * i];
    if (q[0] == 0 && q[1] == 0 && q[2] == 0 && q[3] == 0) {
      throw Error("gaussians", "quats[" + std::to_string(i) + "]", "0 0 0 0",
                  "a rotation needs a non-zero quaternion");
    }
  }
}

template <typename T>
RasterCameraT<T> RasterCameraT<T>::FromPosed(const PosedCamera& posed) {
  const Camera& c = posed.camera;
  if (c.HasDistortion()) {
    throw Error(
        "camera", "model", std::string(c.info().name),
        "the rasterizer takes pinhole cameras; undistort the images first");
  }
  RasterCameraT out;
  out.width = c.width;
  out.height = c.height;
  out.fx = static_cast<T>(c.focal_x());
  out.fy = static_cast<T>(c.focal_y());
  out.cx = static_cast<T>(c.principal_x());
  out.cy = static_cast<T>(c.principal_y());
  out.rotation = posed.cam_from_world.rotation.toRotationMatrix().cast<T>();
  out.translation = posed.cam_from_world.translation.cast<T>();
  return out;
}

template struct GaussianModelT<float>;
template struct GaussianModelT<double>;
template struct RasterCameraT<float>;
template struct RasterCameraT<double>;

}  // namespace pano4d
