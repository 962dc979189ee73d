#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "src/core/posed_camera.h"

namespace pano4d {

// 3D Gaussians in structure-of-arrays layout: the rasterizer's loops read
// one attribute over many Gaussians. Values are the optimiser's parameters:
//   means        N x 3, world coordinates
//   log_scales   N x 3, log of the standard deviations along the local axes
//   quats        N x 4, (w, x, y, z), any non-zero norm (normalised on use)
//   opacities    N, logits (opacity = sigmoid)
//   sh           N x K x 3, K = (sh_degree + 1)^2 coefficients per channel,
//                coefficient-major: sh[(n K + k) 3 + c]
template <typename T>
struct GaussianModelT {
  int sh_degree = 0;  // 0..3
  std::vector<T> means;
  std::vector<T> log_scales;
  std::vector<T> quats;
  std::vector<T> opacities;
  std::vector<T> sh;

  std::size_t size() const { return opacities.size(); }
  int sh_coefficients() const { return (sh_degree + 1) * (sh_degree + 1); }
  void Resize(std::size_t n);
  // Throws pano4d::Error when the arrays disagree in size or the degree is
  // outside 0..3. (The rasterizer takes any values: a zero quaternion or a
  // NaN of a diverging step renders as nothing, and the trainer counts it.)
  void Check() const;
  // Check, and every value finite, every quaternion non-zero: what a scene
  // read from or written to a file must hold (GaussianScene::Check).
  void CheckValues() const;
};

// A pinhole camera as the rasterizer uses it (distortion is removed
// upstream, e.g. by COLMAP's image_undistorter).
template <typename T>
struct RasterCameraT {
  int width = 0;
  int height = 0;
  T fx = 1, fy = 1, cx = 0, cy = 0;
  Eigen::Matrix<T, 3, 3> rotation =
      Eigen::Matrix<T, 3, 3>::Identity();  // cam_from_world
  Eigen::Matrix<T, 3, 1> translation = Eigen::Matrix<T, 3, 1>::Zero();

  // Throws pano4d::Error for a camera with distortion.
  static RasterCameraT FromPosed(const PosedCamera& camera);
  Eigen::Matrix<T, 3, 1> Center() const {
    return -(rotation.transpose() * translation);
  }
  // The point at continuous pixel position (u, v) (pixel x's centre is
  // x + 0.5) with z-depth z: in this camera's frame, computed in S (the
  // warp works in double), and in the world.
  template <typename S>
  Eigen::Matrix<S, 3, 1> CameraPoint(S u, S v, S z) const {
    return Eigen::Matrix<S, 3, 1>((u - S(cx)) / S(fx) * z,
                                  (v - S(cy)) / S(fy) * z, z);
  }
  Eigen::Matrix<T, 3, 1> Unproject(T u, T v, T z) const {
    return rotation.transpose() * (CameraPoint(u, v, z) - translation);
  }
};

// float renders; double is for checking gradients by finite differences.
using GaussianModel = GaussianModelT<float>;
using RasterCamera = RasterCameraT<float>;

}  // namespace pano4d
