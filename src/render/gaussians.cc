#include "src/render/gaussians.h"

#include "src/core/error.h"

namespace pano4d {

void GaussianModel::Resize(std::size_t n) {
  means.resize(3 * n);
  log_scales.resize(3 * n);
  quats.resize(4 * n);
  opacities.resize(n);
  sh.resize(n * sh_coefficients() * 3);
}

void GaussianModel::Check() const {
  if (sh_degree < 0 || sh_degree > 3) {
    throw Error("gaussians", "sh_degree", std::to_string(sh_degree),
                "must be 0..3");
  }
  const std::size_t n = size();
  const auto expect = [&](const std::vector<float>& v, std::size_t per,
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
}

RasterCamera RasterCamera::FromPosed(const PosedCamera& posed) {
  const Camera& c = posed.camera;
  if (c.HasDistortion()) {
    throw Error(
        "camera", "model", std::string(c.info().name),
        "the rasterizer takes pinhole cameras; undistort the images first");
  }
  RasterCamera out;
  out.width = c.width;
  out.height = c.height;
  out.fx = static_cast<float>(c.focal_x());
  out.fy = static_cast<float>(c.focal_y());
  out.cx = static_cast<float>(c.principal_x());
  out.cy = static_cast<float>(c.principal_y());
  out.rotation = posed.cam_from_world.rotation.toRotationMatrix().cast<float>();
  out.translation = posed.cam_from_world.translation.cast<float>();
  return out;
}

}  // namespace pano4d
