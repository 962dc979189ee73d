// Backward pass of the blend: from the forward's saved state (final
// transmittance and last contributor per pixel, sorted ids, tile ranges) to
// gradients with respect to each projected Gaussian.
#include <algorithm>
#include <cmath>

#include "src/core/error.h"
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

  // Each tile's entries are its own, so tiles run in parallel without
  // sharing a gradient slot.
#pragma omp parallel for schedule(dynamic, 1)
  for (int tile = 0; tile < tiles_x * tiles_y; ++tile) {
    const std::uint32_t begin = ranges_[2 * tile];
    const int x_begin = (tile % tiles_x) * kTileSize,
              y_begin = (tile / tiles_x) * kTileSize;
    for (int py = y_begin; py < std::min(y_begin + kTileSize, height); ++py) {
      for (int px = x_begin; px < std::min(x_begin + kTileSize, width); ++px) {
        const std::size_t pixel = static_cast<std::size_t>(py) * width + px;
        const T fx = px + T(0.5), fy = py + T(0.5);
        const T t_final = final_t_[pixel];
        const T dc[3] = {d_rgb.empty() ? T(0) : d_rgb[3 * pixel],
                         d_rgb.empty() ? T(0) : d_rgb[3 * pixel + 1],
                         d_rgb.empty() ? T(0) : d_rgb[3 * pixel + 2]};
        // Outputs: depth_out = D / A with A = 1 - T_final (when A is large
        // enough to hold a surface), alpha_out = A.
        const T accumulated = 1 - t_final;
        T d_acc_depth = 0;
        T d_accumulated = d_alpha.empty() ? T(0) : d_alpha[pixel];
        if (!d_depth.empty() && accumulated > T(kMinAlphaForDepth)) {
          const T depth_sum = out.depth[pixel] * accumulated;
          d_acc_depth = d_depth[pixel] / accumulated;
          d_accumulated -=
              d_depth[pixel] * depth_sum / (accumulated * accumulated);
        }
        // Back to front: what lies behind Gaussian i (the background for the
        // last one), as seen from just after i; transmittance recovered by
        // division (alpha <= kMaxAlpha keeps 1 - alpha >= 0.01).
        T behind[3] = {settings.background.x(), settings.background.y(),
                       settings.background.z()};
        T behind_depth = 0;
        T t = t_final;
        for (std::uint32_t k = last_[pixel]; k-- > begin;) {
          const std::uint32_t g = ids_[k];
          const T dx = fx - p.x[g], dy = fy - p.y[g];
          // Outside the Gaussian's alpha >= kMinAlpha box: the forward never
          // visited this pixel for it.
          if (std::abs(dx) > p.extent_x[g] || std::abs(dy) > p.extent_y[g])
            continue;
          const T power =
              -T(0.5) * (p.conic_a[g] * dx * dx + p.conic_c[g] * dy * dy) -
              p.conic_b[g] * dx * dy;
          if (power > 0) continue;
          const T gauss = std::exp(power);
          const T raw = p.opacity[g] * gauss;
          const T alpha = std::min(T(kMaxAlpha), raw);
          if (alpha < T(kMinAlpha)) continue;
          t /= (1 - alpha);
          const T w = alpha * t;
          const T color[3] = {p.r[g], p.g[g], p.b[g]};
          T* e = &entry_grads_[kPer * static_cast<std::size_t>(k)];
          T d_alpha_i = t * (p.depth[g] - behind_depth) * d_acc_depth +
                        d_accumulated * t_final / (1 - alpha);
          for (int c = 0; c < 3; ++c) {
            e[6 + c] += w * dc[c];
            d_alpha_i += t * (color[c] - behind[c]) * dc[c];
            behind[c] = alpha * color[c] + (1 - alpha) * behind[c];
          }
          e[9] += w * d_acc_depth;
          behind_depth = alpha * p.depth[g] + (1 - alpha) * behind_depth;
          if (raw > T(kMaxAlpha)) continue;  // min(0.99, .) is flat there
          const T d_power = raw * d_alpha_i;
          e[5] += gauss * d_alpha_i;
          e[2] += -T(0.5) * dx * dx * d_power;
          e[3] += -dx * dy * d_power;
          e[4] += -T(0.5) * dy * dy * d_power;
          e[0] += (p.conic_a[g] * dx + p.conic_b[g] * dy) * d_power;
          e[1] += (p.conic_c[g] * dy + p.conic_b[g] * dx) * d_power;
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
