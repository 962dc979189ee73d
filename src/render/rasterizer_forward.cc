// Forward pass: projection, tile binning with a (tile, depth) sort, and
// per-tile front-to-back alpha blending.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <Eigen/Geometry>

#include "src/core/error.h"
#include "src/core/timer.h"
#include "src/render/blend_kernel.h"
#include "src/render/quaternion.h"
#include "src/render/rasterizer.h"
#include "src/render/sh.h"

namespace pano4d {

template <typename T>
void ProjectedGaussiansT<T>::Resize(std::size_t n) {
  for (auto* v : {&x, &y, &depth, &conic_a, &conic_b, &conic_c, &opacity, &r,
                  &g, &b, &extent_x, &extent_y})
    v->resize(n);
  for (auto* v : {&radius, &tile_x0, &tile_y0, &tile_x1, &tile_y1})
    v->resize(n);
  clamped.resize(3 * n);
}

template <typename T>
void RasterizerT<T>::Project(const GaussianModelT<T>& model,
                             const RasterCameraT<T>& camera) {
  const std::size_t n = model.size();
  projected_.Resize(n);
  const int tiles_x = (camera.width + kTileSize - 1) / kTileSize;
  const int tiles_y = (camera.height + kTileSize - 1) / kTileSize;
  const T lim_x = T(kFovClamp) * T(0.5) * camera.width / camera.fx;
  const T lim_y = T(kFovClamp) * T(0.5) * camera.height / camera.fy;
  const Eigen::Matrix<T, 3, 1> center = camera.Center();
  const int k_count = model.sh_coefficients();
  ProjectedGaussiansT<T>& p = projected_;

#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    p.radius[i] = 0;
    const Eigen::Matrix<T, 3, 1> mean(
        model.means[3 * i], model.means[3 * i + 1], model.means[3 * i + 2]);
    const Eigen::Matrix<T, 3, 1> t =
        camera.rotation * mean + camera.translation;
    if (!(t.z() > T(kNearPlane)) || !t.allFinite()) continue;

    // 3D covariance R S S^T R^T from the normalised quaternion and scales.
    const Eigen::Matrix<T, 3, 3> rot =
        UnitQuaternion<T>(&model.quats[4 * i]).Rotation();
    const Eigen::Matrix<T, 3, 1> scale(std::exp(model.log_scales[3 * i]),
                                       std::exp(model.log_scales[3 * i + 1]),
                                       std::exp(model.log_scales[3 * i + 2]));
    const Eigen::Matrix<T, 3, 3> m = rot * scale.asDiagonal();
    const Eigen::Matrix<T, 3, 3> sigma = m * m.transpose();

    // EWA: J W Sigma W^T J^T with the point clamped to kFovClamp x FOV.
    const T inv_z = T(1.0) / t.z();
    const T tx = std::clamp(t.x() * inv_z, -lim_x, lim_x) * t.z();
    const T ty = std::clamp(t.y() * inv_z, -lim_y, lim_y) * t.z();
    Eigen::Matrix<T, 2, 3> j;
    j << camera.fx * inv_z, 0, -camera.fx * tx * inv_z * inv_z,  //
        0, camera.fy * inv_z, -camera.fy * ty * inv_z * inv_z;
    const Eigen::Matrix<T, 2, 3> jw = j * camera.rotation;
    const Eigen::Matrix<T, 2, 2> cov =
        jw * sigma * jw.transpose() +
        T(kLowPass) * Eigen::Matrix<T, 2, 2>::Identity();
    const T det = cov(0, 0) * cov(1, 1) - cov(0, 1) * cov(0, 1);
    if (!(det > 0) || !std::isfinite(det)) continue;

    // A Gaussian below kMinAlpha everywhere never contributes.
    const T opacity = T(1.0) / (T(1.0) + std::exp(-model.opacities[i]));
    if (!(opacity >= T(kMinAlpha))) continue;
    // alpha >= kMinAlpha <=> d^T conic d <= 2 ln(opacity / kMinAlpha):
    // the bounding box of that ellipse has half-sizes sqrt(k cov_xx), sqrt(k
    // cov_yy).
    const T k = T(2.0) * std::log(opacity / T(kMinAlpha));
    const T extent_x = std::sqrt(k * cov(0, 0)) + T(kAlphaBoxMargin);
    const T extent_y = std::sqrt(k * cov(1, 1)) + T(kAlphaBoxMargin);
    const T mid = T(0.5) * (cov(0, 0) + cov(1, 1));
    const T lambda = mid + std::sqrt(std::max(T(0.1), mid * mid - det));
    const T radius =
        std::min(T(kMaxRadius), std::ceil(T(3.0) * std::sqrt(lambda)));
    const T px = camera.fx * t.x() * inv_z + camera.cx;
    const T py = camera.fy * t.y() * inv_z + camera.cy;
    if (!std::isfinite(radius) || !std::isfinite(px) || !std::isfinite(py))
      continue;
    // Tiles touched by the 3-sigma square around the mean, [x0, x1).
    const auto tile = [](T v, int tiles) {
      return static_cast<int>(
          std::clamp(v / kTileSize, T(0.0), static_cast<T>(tiles)));
    };
    const int x0 = tile(px - radius, tiles_x),
              x1 = tile(px + radius + kTileSize - 1, tiles_x);
    const int y0 = tile(py - radius, tiles_y),
              y1 = tile(py + radius + kTileSize - 1, tiles_y);
    if (x1 <= x0 || y1 <= y0) continue;

    p.x[i] = px;
    p.y[i] = py;
    p.depth[i] = t.z();
    p.conic_a[i] = cov(1, 1) / det;
    p.conic_b[i] = -cov(0, 1) / det;
    p.conic_c[i] = cov(0, 0) / det;
    p.opacity[i] = opacity;
    p.extent_x[i] = extent_x;
    p.extent_y[i] = extent_y;
    bool clamped[3];
    const Eigen::Matrix<T, 3, 1> color =
        ShColor(model.sh_degree,
                model.sh.data() + static_cast<std::size_t>(i) * k_count * 3,
                (mean - center).normalized(), clamped);
    p.r[i] = color.x();
    p.g[i] = color.y();
    p.b[i] = color.z();
    for (int c = 0; c < 3; ++c) p.clamped[3 * i + c] = clamped[c];
    p.tile_x0[i] = x0;
    p.tile_x1[i] = x1;
    p.tile_y0[i] = y0;
    p.tile_y1[i] = y1;
    p.radius[i] = static_cast<int>(radius);
  }
}

template <typename T>
void RasterizerT<T>::Bin(const RasterCameraT<T>& camera) {
  const std::size_t n = projected_.radius.size();
  const int tiles_x = (camera.width + kTileSize - 1) / kTileSize;
  const int tiles_y = (camera.height + kTileSize - 1) / kTileSize;
  const ProjectedGaussiansT<T>& p = projected_;

  offsets_.resize(n + 1);
  offsets_[0] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t count =
        p.radius[i] > 0
            ? static_cast<std::uint64_t>(p.tile_x1[i] - p.tile_x0[i]) *
                  (p.tile_y1[i] - p.tile_y0[i])
            : 0;
    if (offsets_[i] + count > UINT32_MAX) {
      throw Error("rasterizer", "tile entries",
                  std::to_string(offsets_[i] + count),
                  "more than 2^32 (Gaussian, tile) pairs");
    }
    offsets_[i + 1] = static_cast<std::uint32_t>(offsets_[i] + count);
  }
  const std::uint32_t total = offsets_[n];
  keys_.resize(total);
  ids_.resize(total);
  // Key: tile in the high 32 bits, the depth's T bits (monotonic for
  // positive floats) in the low 32; the Gaussian index breaks ties, so the
  // order is total and the same whatever the threads.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    if (p.radius[i] == 0) continue;
    // The float's bits, whatever T is: the key has 32 bits for depth.
    const float depth = static_cast<float>(p.depth[i]);
    std::uint32_t depth_bits;
    std::memcpy(&depth_bits, &depth, sizeof(depth_bits));
    std::uint32_t k = offsets_[i];
    for (int ty = p.tile_y0[i]; ty < p.tile_y1[i]; ++ty) {
      for (int tx = p.tile_x0[i]; tx < p.tile_x1[i]; ++tx) {
        keys_[k] =
            (static_cast<std::uint64_t>(ty * tiles_x + tx) << 32) | depth_bits;
        ids_[k] = static_cast<std::uint32_t>(i);
        ++k;
      }
    }
  }
  // LSD radix sort of the (key, id) pairs on the key, 8 bits a pass, over
  // the bits the keys use (32 of depth, then the tile). Radix sort is
  // stable and the entries were written in Gaussian order, so equal keys
  // keep index order: the order is total, as the blend and its backward
  // need.
  const std::uint64_t tiles = static_cast<std::uint64_t>(tiles_x) * tiles_y;
  int key_bits = 32;
  while ((std::uint64_t{1} << (key_bits - 32)) < tiles) ++key_bits;
  key_scratch_.resize(total);
  scratch_.resize(total);
  for (int shift = 0; shift < key_bits; shift += 8) {
    std::uint32_t count[257] = {};
    for (std::uint32_t k = 0; k < total; ++k)
      ++count[((keys_[k] >> shift) & 0xff) + 1];
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (std::uint32_t k = 0; k < total; ++k) {
      const std::uint32_t slot = count[(keys_[k] >> shift) & 0xff]++;
      key_scratch_[slot] = keys_[k];
      scratch_[slot] = ids_[k];
    }
    keys_.swap(key_scratch_);
    ids_.swap(scratch_);
  }
  ranges_.assign(2 * tiles, 0);
  for (std::uint32_t k = 0; k < total; ++k) {
    const std::uint32_t tile = static_cast<std::uint32_t>(keys_[k] >> 32);
    if (k == 0 || static_cast<std::uint32_t>(keys_[k - 1] >> 32) != tile)
      ranges_[2 * tile] = k;
    ranges_[2 * tile + 1] = k + 1;
  }
}

// How many Gaussians the blend processes between checks whether every pixel
// of a tile has stopped.
constexpr std::uint32_t kOpenCheckInterval = 16;

template <typename T>
void RasterizerT<T>::Blend(const RasterCameraT<T>& camera,
                           const RasterSettingsT<T>& settings,
                           RenderOutputT<T>* out) {
  const int width = camera.width, height = camera.height;
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  out->width = width;
  out->height = height;
  out->rgb.resize(3 * pixels);
  out->depth.resize(pixels);
  out->alpha.resize(pixels);
  final_t_.resize(pixels);
  last_.resize(pixels);
  const ProjectedGaussiansT<T>& p = projected_;
  std::uint64_t evaluations = 0;

  // Gaussian-major within a tile: each Gaussian, front to back, updates the
  // rows of its alpha >= kMinAlpha box. Every pixel still sees its Gaussians
  // in depth order and stops once transmittance would drop below
  // kMinTransmittance, exactly as a pixel-major loop, but rows a Gaussian
  // cannot reach are never visited. A row is one branch-free lane loop
  // (blend_kernel.h): lanes that do not change select their old values.
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : evaluations)
  for (int tile = 0; tile < tiles_x * tiles_y; ++tile) {
    constexpr int kTilePixels = kTileSize * kTileSize;
    // open = 1 while a pixel still blends, 0 once it has stopped (and for
    // lanes beyond the image's right edge): alpha * open is the alpha a
    // pixel sees, so done pixels need no branch.
    alignas(64) T t[kTilePixels], cr[kTilePixels], cg[kTilePixels],
        cb[kTilePixels], cd[kTilePixels], open[kTilePixels];
    alignas(64) std::uint32_t last[kTilePixels];
    const std::uint32_t begin = ranges_[2 * tile], end = ranges_[2 * tile + 1];
    const TileRect<T> rect(tile, tiles_x, width, height);
    for (int i = 0; i < kTilePixels; ++i) {
      t[i] = T(1.0);
      cr[i] = cg[i] = cb[i] = cd[i] = T(0.0);
      last[i] = begin;
      open[i] = rect.x_begin + i % kTileSize < rect.x_end ? T(1) : T(0);
    }
    for (std::uint32_t k = begin; k < end; ++k) {
      // Once every pixel has stopped the rest of the tile's Gaussians
      // cannot change it; checked now and then, as the scan costs a row.
      if ((k - begin) % kOpenCheckInterval == kOpenCheckInterval - 1 &&
          std::none_of(open, open + kTilePixels, [](T o) { return o > 0; }))
        break;
      const std::uint32_t g = ids_[k];
      TileBox box;
      if (!BoxInTile(p, g, rect.x_begin, rect.x_end, rect.y_begin, rect.y_end,
                     &box))
        continue;
      const T gx = p.x[g], op = p.opacity[g];
      const T red = p.r[g], green = p.g[g], blue = p.b[g], z = p.depth[g];
      evaluations += static_cast<std::uint64_t>(box.y1 - box.y0 + 1) *
                     (box.group1 - box.group0 + 1) * kLaneGroup;
      for (int py = box.y0; py <= box.y1; ++py) {
        const ConicRow<T> conic(p.conic_a[g], p.conic_b[g], p.conic_c[g],
                                py + T(0.5) - p.y[g]);
        for (int group = box.group0; group <= box.group1; ++group) {
          const int first =
              (py - rect.y_begin) * kTileSize + group * kLaneGroup;
          T *rt = t + first, *rr = cr + first, *rg = cg + first,
            *rb = cb + first, *rd = cd + first, *ropen = open + first;
          std::uint32_t* rlast = last + first;
          const T* rx = rect.lane_x + group * kLaneGroup;
          for (int lane = 0; lane < kLaneGroup; ++lane) {
            const T alpha =
                ropen[lane] * EvaluateAlpha(conic, op, rx[lane] - gx).alpha;
            const T before = rt[lane];
            const T next = before * (1 - alpha);
            // Only a contributing pair can stop a pixel: transmittance
            // never goes below kMinTransmittance, so alpha = 0 keeps
            // next = before.
            const bool stop = next < T(kMinTransmittance);
            const T w = stop ? T(0) : alpha * before;
            rr[lane] = MulAdd(w, red, rr[lane]);
            rg[lane] = MulAdd(w, green, rg[lane]);
            rb[lane] = MulAdd(w, blue, rb[lane]);
            rd[lane] = MulAdd(w, z, rd[lane]);
            rt[lane] = stop ? before : next;
            // w > 0 exactly when the pair blended (alpha >= kMinAlpha and
            // transmittance >= kMinTransmittance).
            rlast[lane] = w > T(0) ? k + 1 : rlast[lane];
            ropen[lane] = stop ? T(0) : ropen[lane];
          }
        }
      }
    }
    for (int py = rect.y_begin; py < rect.y_end; ++py) {
      for (int px = rect.x_begin; px < rect.x_end; ++px) {
        const int i = (py - rect.y_begin) * kTileSize + (px - rect.x_begin);
        const std::size_t pixel = static_cast<std::size_t>(py) * width + px;
        out->rgb[3 * pixel] = cr[i] + t[i] * settings.background.x();
        out->rgb[3 * pixel + 1] = cg[i] + t[i] * settings.background.y();
        out->rgb[3 * pixel + 2] = cb[i] + t[i] * settings.background.z();
        const T alpha = 1 - t[i];
        out->alpha[pixel] = alpha;
        out->depth[pixel] =
            alpha > T(kMinAlphaForDepth) ? cd[i] / alpha : T(0.0);
        final_t_[pixel] = t[i];
        last_[pixel] = last[i];
      }
    }
  }
  stats_.pixel_evaluations = evaluations;
}

template <typename T>
void RasterizerT<T>::Forward(const GaussianModelT<T>& model,
                             const RasterCameraT<T>& camera,
                             const RasterSettingsT<T>& settings,
                             RenderOutputT<T>* out) {
  model.Check();
  if (camera.width <= 0 || camera.height <= 0) {
    throw Error(
        "rasterizer", "camera",
        std::to_string(camera.width) + "x" + std::to_string(camera.height),
        "image size must be positive");
  }
  Timer timer;
  Project(model, camera);
  stats_.project_ms = 1e3 * timer.WallSeconds();
  timer.Restart();
  Bin(camera);
  stats_.bin_ms = 1e3 * timer.WallSeconds();
  stats_.visible = static_cast<std::uint64_t>(
      std::count_if(projected_.radius.begin(), projected_.radius.end(),
                    [](int r) { return r > 0; }));
  stats_.tile_entries = ids_.size();
  timer.Restart();
  Blend(camera, settings, out);
  stats_.blend_ms = 1e3 * timer.WallSeconds();
}

template <typename T>
void RasterizerT<T>::ForwardProjected(const ProjectedGaussiansT<T>& projected,
                                      const RasterCameraT<T>& camera,
                                      const RasterSettingsT<T>& settings,
                                      RenderOutputT<T>* out) {
  projected_ = projected;
  Bin(camera);
  stats_.tile_entries = ids_.size();
  Blend(camera, settings, out);
}

template struct ProjectedGaussiansT<float>;
template struct ProjectedGaussiansT<double>;
template class RasterizerT<float>;
template class RasterizerT<double>;

}  // namespace pano4d
