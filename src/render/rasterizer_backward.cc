// Backward pass of the blend: from the forward's saved state (final
// transmittance and last contributor per pixel, sorted ids, tile ranges) to
// gradients with respect to each projected Gaussian.
#include <algorithm>
#include <cmath>

#include "src/core/error.h"
#include "src/render/blend_span.h"
#include "src/render/rasterizer.h"

namespace pano4d {

template <typename T>
void ProjectedGradientsT<T>::Assign(std::size_t n) {
  for (auto* v :
       {&x, &y, &conic_a, &conic_b, &conic_c, &opacity, &r, &g, &b, &depth})
    v->assign(n, T(0));
}

template <typename T>
void RasterizerT<T>::BlendBackward(const RasterCameraT<T>& camera,
                                   const RasterSettingsT<T>& settings,
                                   const RenderOutputT<T>& out,
                                   const std::vector<T>& d_rgb,
                                   const std::vector<T>& d_depth,
                                   const std::vector<T>& d_alpha,
                                   ProjectedGradientsT<T>* grad) {
  const int width = camera.width, height = camera.height;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  if ((!d_rgb.empty() && d_rgb.size() != 3 * pixels) ||
      (!d_depth.empty() && d_depth.size() != pixels) ||
      (!d_alpha.empty() && d_alpha.size() != pixels) ||
      final_t_.size() != pixels) {
    throw Error("rasterizer", "backward", "",
                "output gradients do not match the last forward pass");
  }
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  const ProjectedGaussiansT<T>& p = projected_;
  constexpr int kPer = 10;  // x, y, conic a b c, opacity, r g b, depth
  entry_grads_.assign(kPer * ids_.size(), T(0));

  // Gaussian-major, back to front, as the forward: each Gaussian updates
  // the pixels of its span (GaussianSpan) whose last contributor lies beyond
  // it, so every pixel sees the same Gaussians in reverse order as a
  // pixel-major walk would. A tile's entries are its own: tiles run in
  // parallel without sharing a gradient slot.
#pragma omp parallel for schedule(dynamic, 1)
  for (int tile = 0; tile < tiles_x * tiles_y; ++tile) {
    constexpr int kTilePixels = kTileSize * kTileSize;
    T t[kTilePixels], t_final[kTilePixels], d_acc_depth[kTilePixels],
        d_accumulated[kTilePixels];
    T dc[3][kTilePixels], behind[3][kTilePixels], behind_depth[kTilePixels];
    std::uint32_t last[kTilePixels];
    const std::uint32_t begin = ranges_[2 * tile], end = ranges_[2 * tile + 1];
    const int x_begin = (tile % tiles_x) * kTileSize,
              y_begin = (tile / tiles_x) * kTileSize;
    const int x_end = std::min(x_begin + kTileSize, width),
              y_end = std::min(y_begin + kTileSize, height);
    for (int py = y_begin; py < y_end; ++py) {
      for (int px = x_begin; px < x_end; ++px) {
        const int i = (py - y_begin) * kTileSize + (px - x_begin);
        const std::size_t pixel = static_cast<std::size_t>(py) * width + px;
        t_final[i] = t[i] = final_t_[pixel];
        last[i] = last_[pixel];
        for (int c = 0; c < 3; ++c) {
          dc[c][i] = d_rgb.empty() ? T(0) : d_rgb[3 * pixel + c];
          behind[c][i] = settings.background(c);
        }
        behind_depth[i] = 0;
        // Outputs: depth_out = D / A with A = 1 - T_final (when A is large
        // enough to hold a surface), alpha_out = A.
        const T accumulated = 1 - t_final[i];
        d_acc_depth[i] = 0;
        d_accumulated[i] = d_alpha.empty() ? T(0) : d_alpha[pixel];
        if (!d_depth.empty() && accumulated > T(kMinAlphaForDepth)) {
          const T depth_sum = out.depth[pixel] * accumulated;
          d_acc_depth[i] = d_depth[pixel] / accumulated;
          d_accumulated[i] -=
              d_depth[pixel] * depth_sum / (accumulated * accumulated);
        }
      }
    }
    for (std::uint32_t k = end; k-- > begin;) {
      const std::uint32_t g = ids_[k];
      const GaussianSpan<T> span(p, g, x_begin, x_end, y_begin, y_end);
      const T gx = p.x[g], gy = p.y[g], ca = p.conic_a[g], cb = p.conic_b[g],
              cc = p.conic_c[g];
      const T op = p.opacity[g], z = p.depth[g];
      const T color[3] = {p.r[g], p.g[g], p.b[g]};
      T* e = &entry_grads_[kPer * static_cast<std::size_t>(k)];
      for (int py = span.first_row(); py <= span.last_row(); ++py) {
        int x0, x1;
        if (!span.Row(py, &x0, &x1)) continue;
        const T dy = py + T(0.5) - gy;
        for (int px = x0; px <= x1; ++px) {
          const int i = (py - y_begin) * kTileSize + (px - x_begin);
          if (k >= last[i]) continue;  // behind this pixel's last contributor
          const T dx = px + T(0.5) - gx;
          const T power =
              -T(0.5) * (ca * dx * dx + cc * dy * dy) - cb * dx * dy;
          if (power > 0) continue;
          const T gauss = std::exp(power);
          const T raw = op * gauss;
          const T alpha = std::min(T(kMaxAlpha), raw);
          if (alpha < T(kMinAlpha)) continue;
          // Transmittance before this Gaussian, recovered by division
          // (alpha <= kMaxAlpha keeps 1 - alpha >= 0.01).
          t[i] /= (1 - alpha);
          const T w = alpha * t[i];
          T d_alpha_i = t[i] * (z - behind_depth[i]) * d_acc_depth[i] +
                        d_accumulated[i] * t_final[i] / (1 - alpha);
          for (int c = 0; c < 3; ++c) {
            e[6 + c] += w * dc[c][i];
            d_alpha_i += t[i] * (color[c] - behind[c][i]) * dc[c][i];
            behind[c][i] = alpha * color[c] + (1 - alpha) * behind[c][i];
          }
          e[9] += w * d_acc_depth[i];
          behind_depth[i] = alpha * z + (1 - alpha) * behind_depth[i];
          if (raw > T(kMaxAlpha)) continue;  // min(0.99, .) is flat there
          const T d_power = raw * d_alpha_i;
          e[5] += gauss * d_alpha_i;
          e[2] += -T(0.5) * dx * dx * d_power;
          e[3] += -dx * dy * d_power;
          e[4] += -T(0.5) * dy * dy * d_power;
          e[0] += (ca * dx + cb * dy) * d_power;
          e[1] += (cc * dy + cb * dx) * d_power;
        }
      }
    }
  }

  grad->Assign(p.x.size());
  std::vector<T>* fields[kPer] = {
      &grad->x,       &grad->y, &grad->conic_a, &grad->conic_b, &grad->conic_c,
      &grad->opacity, &grad->r, &grad->g,       &grad->b,       &grad->depth};
  for (std::size_t k = 0; k < ids_.size(); ++k) {
    for (int f = 0; f < kPer; ++f)
      (*fields[f])[ids_[k]] += entry_grads_[kPer * k + f];
  }
}

template struct ProjectedGradientsT<float>;
template struct ProjectedGradientsT<double>;
template void RasterizerT<float>::BlendBackward(const RasterCameraT<float>&,
                                                const RasterSettingsT<float>&,
                                                const RenderOutputT<float>&,
                                                const std::vector<float>&,
                                                const std::vector<float>&,
                                                const std::vector<float>&,
                                                ProjectedGradientsT<float>*);
template void RasterizerT<double>::BlendBackward(const RasterCameraT<double>&,
                                                 const RasterSettingsT<double>&,
                                                 const RenderOutputT<double>&,
                                                 const std::vector<double>&,
                                                 const std::vector<double>&,
                                                 const std::vector<double>&,
                                                 ProjectedGradientsT<double>*);

}  // namespace pano4d
