// Rasterize to pixels, forward and backward (rasterize_to_pixels.h).
#include "src/render/rasterize_to_pixels.h"

#include <algorithm>
#include <cmath>

#include "src/core/timer.h"
#include "src/render/blend_kernel.h"

namespace pano4d {

// How many Gaussians the blend processes between checks whether every pixel
// of a tile has stopped.
constexpr std::uint32_t kOpenCheckInterval = 16;

namespace {

// One tile of the forward: its pixels' transmittance, colour and depth
// sums, and whether each still blends.
template <typename T>
struct ForwardTile {
  static constexpr int kPixels = kTileSize * kTileSize;
  // open = 1 while a pixel still blends, 0 once it has stopped (and for
  // lanes beyond the image's right edge): alpha * open is the alpha a pixel
  // sees, so done pixels need no branch.
  alignas(64) T t[kPixels], cr[kPixels], cg[kPixels], cb[kPixels], cd[kPixels],
      open[kPixels];
  alignas(64) std::uint32_t last[kPixels];

  ForwardTile(const TileRect<T>& rect, std::uint32_t begin) {
    for (int i = 0; i < kPixels; ++i) {
      t[i] = T(1.0);
      cr[i] = cg[i] = cb[i] = cd[i] = T(0.0);
      last[i] = begin;
      open[i] = rect.x_begin + i % kTileSize < rect.x_end ? T(1) : T(0);
    }
  }
  bool AllStopped() const {
    return std::none_of(open, open + kPixels, [](T o) { return o > 0; });
  }
  // Entry k (Gaussian g, its box in the tile) blended into the rows of its
  // box, one branch-free lane loop a row (blend_kernel.h): lanes that do not
  // change select their old values.
  [[gnu::always_inline]] inline void Blend(const ProjectedGaussiansT<T>& p,
                                           std::uint32_t g, std::uint32_t k,
                                           const TileBox& box,
                                           const TileRect<T>& rect) {
    const T gx = p.x[g], op = p.opacity[g];
    const T red = p.r[g], green = p.g[g], blue = p.b[g], z = p.depth[g];
    for (int py = box.y0; py <= box.y1; ++py) {
      const ConicRow<T> conic(p.conic_a[g], p.conic_b[g], p.conic_c[g],
                              py + T(0.5) - p.y[g]);
      for (int group = box.group0; group <= box.group1; ++group) {
        const int first = (py - rect.y_begin) * kTileSize + group * kLaneGroup;
        T *rt = t + first, *rr = cr + first, *rg = cg + first, *rb = cb + first,
          *rd = cd + first, *ropen = open + first;
        std::uint32_t* rlast = last + first;
        const T* rx = rect.lane_x + group * kLaneGroup;
        for (int lane = 0; lane < kLaneGroup; ++lane) {
          const T alpha =
              ropen[lane] * EvaluateAlpha(conic, op, rx[lane] - gx).alpha;
          const T before = rt[lane];
          const T next = before * (1 - alpha);
          // Only a contributing pair can stop a pixel: transmittance never
          // goes below kMinTransmittance, so alpha = 0 keeps next = before.
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
  // The tile's pixels into the outputs and the state the backward reads.
  [[gnu::always_inline]] inline void Write(const RasterSettingsT<T>& settings,
                                           const TileRect<T>& rect,
                                           RasterStateT<T>* state,
                                           RenderOutputT<T>* out) const {
    const int width = state->width;
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
        state->final_transmittance[pixel] = t[i];
        state->last_contributor[pixel] = last[i];
      }
    }
  }
};

}  // namespace

template <typename T>
std::uint64_t RasterizeToPixelsForward(const RasterSettingsT<T>& settings,
                                       RasterStateT<T>* state,
                                       RenderOutputT<T>* out) {
  const int width = state->width, height = state->height;
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  out->width = width;
  out->height = height;
  out->rgb.resize(3 * pixels);
  out->depth.resize(pixels);
  out->alpha.resize(pixels);
  state->final_transmittance.resize(pixels);
  state->last_contributor.resize(pixels);
  const ProjectedGaussiansT<T>& p = state->projected;
  const std::vector<std::uint32_t>& ids = state->sorted_ids;
  const std::vector<std::uint32_t>& ranges = state->tile_ranges;
  std::uint64_t evaluations = 0;

  // Gaussian-major within a tile: each Gaussian, front to back, updates the
  // rows of its alpha >= kMinAlpha box. Every pixel still sees its Gaussians
  // in depth order and stops once transmittance would drop below
  // kMinTransmittance, exactly as a pixel-major loop, but rows a Gaussian
  // cannot reach are never visited.
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : evaluations)
  for (int tile = 0; tile < tiles_x * tiles_y; ++tile) {
    const std::uint32_t begin = ranges[2 * tile], end = ranges[2 * tile + 1];
    const TileRect<T> rect(tile, tiles_x, width, height);
    ForwardTile<T> f(rect, begin);
    for (std::uint32_t k = begin; k < end; ++k) {
      // Once every pixel has stopped the rest of the tile's Gaussians
      // cannot change it; checked now and then, as the scan costs a row.
      if ((k - begin) % kOpenCheckInterval == kOpenCheckInterval - 1 &&
          f.AllStopped())
        break;
      const std::uint32_t g = ids[k];
      TileBox box;
      if (!BoxInTile(p, g, rect.x_begin, rect.x_end, rect.y_begin, rect.y_end,
                     &box))
        continue;
      evaluations += static_cast<std::uint64_t>(box.y1 - box.y0 + 1) *
                     (box.group1 - box.group0 + 1) * kLaneGroup;
      f.Blend(p, g, k, box, rect);
    }
    f.Write(settings, rect, state, out);
  }
  return evaluations;
}

namespace {

// Per entry: x, y, conic a b c, opacity, r g b, depth.
constexpr int kPer = 10;

// One tile of the backward: its pixels' state, restored from the forward's
// and walked back to front, and each lane slot's share of the current
// Gaussian's gradient: kLaneGroup slots, each summing its lane of every
// group the Gaussian's box covers. As wide as a group rather than a tile
// row, so that a small Gaussian clears and reduces 80 sums, not 160. Local
// arrays of the tile loop, passed to inlined functions: as members of one
// struct the compiler could not tell the rows apart, and the lane loops did not
// vectorise (a 4x slower backward, measured).
template <typename T>
struct BackwardPixels {
  T* t;
  T* t_final;
  T* d_acc_depth;
  T* d_accumulated;
  T (*dc)[kTileSize * kTileSize];
  T (*behind)[kTileSize * kTileSize];
  T* behind_depth;
  T (*lane_sum)[kLaneGroup];
  std::uint32_t* last;
};

// Pixels beyond the image (right or bottom edge tiles) have no contributor:
// last = 0 keeps every lane loop from touching them.
template <typename T>
[[gnu::always_inline]] inline void LoadBackwardTile(
    const RasterSettingsT<T>& settings, const RasterStateT<T>& state,
    const RenderOutputT<T>& out, const RenderGradientsT<T>& d_out,
    const TileRect<T>& rect, const BackwardPixels<T>& b) {
  T *t = b.t, *t_final = b.t_final, *d_acc_depth = b.d_acc_depth,
    *d_accumulated = b.d_accumulated, *behind_depth = b.behind_depth;
  T(*dc)[kTileSize * kTileSize] = b.dc;
  T(*behind)[kTileSize * kTileSize] = b.behind;
  std::uint32_t* last = b.last;
  constexpr int kPixels = kTileSize * kTileSize;
  const int width = state.width;
  const std::vector<T>&d_rgb = d_out.rgb, &d_depth = d_out.depth,
        &d_alpha = d_out.alpha;
  for (int i = 0; i < kPixels; ++i) {
    last[i] = 0;
    t[i] = t_final[i] = T(1);
    d_acc_depth[i] = d_accumulated[i] = behind_depth[i] = T(0);
    for (int c = 0; c < 3; ++c) dc[c][i] = behind[c][i] = T(0);
  }
  for (int py = rect.y_begin; py < rect.y_end; ++py) {
    for (int px = rect.x_begin; px < rect.x_end; ++px) {
      const int i = (py - rect.y_begin) * kTileSize + (px - rect.x_begin);
      const std::size_t pixel = static_cast<std::size_t>(py) * width + px;
      t_final[i] = t[i] = state.final_transmittance[pixel];
      last[i] = state.last_contributor[pixel];
      for (int c = 0; c < 3; ++c) {
        dc[c][i] = d_rgb.empty() ? T(0) : d_rgb[3 * pixel + c];
        behind[c][i] = settings.background(c);
      }
      // Outputs: depth_out = D / A with A = 1 - T_final (when A is large
      // enough to hold a surface), alpha_out = A.
      const T accumulated = 1 - t_final[i];
      d_accumulated[i] = d_alpha.empty() ? T(0) : d_alpha[pixel];
      if (!d_depth.empty() && accumulated > T(kMinAlphaForDepth)) {
        const T depth_sum = out.depth[pixel] * accumulated;
        d_acc_depth[i] = d_depth[pixel] / accumulated;
        d_accumulated[i] -=
            d_depth[pixel] * depth_sum / (accumulated * accumulated);
      }
    }
  }
}

// Entry k (Gaussian g, its box in the tile) undone in every pixel it
// blended in, its gradient summed into e[kPer].
template <typename T>
[[gnu::always_inline]] inline void BackwardGaussian(
    const ProjectedGaussiansT<T>& p, std::uint32_t g, std::uint32_t k,
    const TileBox& box, const TileRect<T>& rect, const BackwardPixels<T>& b,
    T* e) {
  T *t = b.t, *t_final = b.t_final, *d_acc_depth = b.d_acc_depth,
    *d_accumulated = b.d_accumulated, *behind_depth = b.behind_depth;
  T(*dc)[kTileSize * kTileSize] = b.dc;
  T(*behind)[kTileSize * kTileSize] = b.behind;
  T(*lane_sum)[kLaneGroup] = b.lane_sum;
  const std::uint32_t* last = b.last;
  const T gx = p.x[g], ca = p.conic_a[g], cb = p.conic_b[g], cc = p.conic_c[g];
  const T op = p.opacity[g], z = p.depth[g];
  const T red = p.r[g], green = p.g[g], blue = p.b[g];
  for (int f = 0; f < kPer; ++f)
    std::fill(lane_sum[f], lane_sum[f] + kLaneGroup, T(0));
  for (int py = box.y0; py <= box.y1; ++py) {
    const T dy = py + T(0.5) - p.y[g];
    const ConicRow<T> conic(ca, cb, cc, dy);
    for (int group = box.group0; group <= box.group1; ++group) {
      const int first = (py - rect.y_begin) * kTileSize + group * kLaneGroup;
      const int lane0 = group * kLaneGroup;
      T *rt = t + first, *rbr = behind[0] + first, *rbg = behind[1] + first,
        *rbb = behind[2] + first, *rbd = behind_depth + first;
      const T *rdr = dc[0] + first, *rdg = dc[1] + first, *rdb = dc[2] + first,
              *rad = d_acc_depth + first, *racc = d_accumulated + first,
              *rfin = t_final + first;
      const std::uint32_t* rlast = last + first;
      for (int lane = 0; lane < kLaneGroup; ++lane) {
        const T dx = rect.lane_x[lane0 + lane] - gx;
        const PixelAlpha<T> a = EvaluateAlpha(conic, op, dx);
        // No contribution behind this pixel's last contributor.
        const T alpha = k < rlast[lane] ? a.alpha : T(0);
        const T keep = 1 - alpha;
        // Transmittance before this Gaussian, recovered by division
        // (alpha <= kMaxAlpha keeps 1 - alpha >= 0.01).
        const T before = rt[lane] / keep;
        rt[lane] = before;
        const T w = alpha * before;
        // dL/dalpha: this Gaussian's colour and depth against what lies
        // behind it, and the accumulated alpha's share.
        T d_alpha_all = racc[lane] * rfin[lane] / keep;
        d_alpha_all = MulAdd(before * (z - rbd[lane]), rad[lane], d_alpha_all);
        d_alpha_all =
            MulAdd(before * (red - rbr[lane]), rdr[lane], d_alpha_all);
        d_alpha_all =
            MulAdd(before * (green - rbg[lane]), rdg[lane], d_alpha_all);
        d_alpha_all =
            MulAdd(before * (blue - rbb[lane]), rdb[lane], d_alpha_all);
        T* sum = &lane_sum[0][lane];
        sum[6 * kLaneGroup] = MulAdd(w, rdr[lane], sum[6 * kLaneGroup]);
        sum[7 * kLaneGroup] = MulAdd(w, rdg[lane], sum[7 * kLaneGroup]);
        sum[8 * kLaneGroup] = MulAdd(w, rdb[lane], sum[8 * kLaneGroup]);
        sum[9 * kLaneGroup] = MulAdd(w, rad[lane], sum[9 * kLaneGroup]);
        rbr[lane] = MulAdd(alpha, red, keep * rbr[lane]);
        rbg[lane] = MulAdd(alpha, green, keep * rbg[lane]);
        rbb[lane] = MulAdd(alpha, blue, keep * rbb[lane]);
        rbd[lane] = MulAdd(alpha, z, keep * rbd[lane]);
        // Only blended pairs pass a gradient to the Gaussian's shape,
        // and min(kMaxAlpha, .) is flat where it clamps.
        const T d_alpha = alpha > T(0) ? d_alpha_all : T(0);
        const T d_raw = a.raw <= T(kMaxAlpha) ? d_alpha : T(0);
        const T d_power = a.raw * d_raw;
        sum[5 * kLaneGroup] = MulAdd(a.gauss, d_raw, sum[5 * kLaneGroup]);
        sum[2 * kLaneGroup] =
            MulAdd(-T(0.5) * dx * dx, d_power, sum[2 * kLaneGroup]);
        sum[3 * kLaneGroup] = MulAdd(-dx * dy, d_power, sum[3 * kLaneGroup]);
        sum[4 * kLaneGroup] =
            MulAdd(-T(0.5) * dy * dy, d_power, sum[4 * kLaneGroup]);
        sum[0] = MulAdd(MulAdd(ca, dx, cb * dy), d_power, sum[0]);
        sum[kLaneGroup] =
            MulAdd(MulAdd(cc, dy, cb * dx), d_power, sum[kLaneGroup]);
      }
    }
  }
  for (int f = 0; f < kPer; ++f) {
    T sum = 0;
    for (int lane = 0; lane < kLaneGroup; ++lane) sum += lane_sum[f][lane];
    e[f] = sum;
  }
}

// Each Gaussian's entries summed in entry order (its tiles' order), the
// Gaussians in parallel: the same sums whatever the threads.
template <typename T>
void SumEntryGradients(const RasterStateT<T>& state,
                       const std::vector<T>& entry_grads,
                       ProjectedGradientsT<T>* grad) {
  const ProjectedGaussiansT<T>& p = state.projected;
  grad->Resize(p.size());
  T* fields[kPer] = {grad->x.data(),       grad->y.data(),
                     grad->conic_a.data(), grad->conic_b.data(),
                     grad->conic_c.data(), grad->opacity.data(),
                     grad->r.data(),       grad->g.data(),
                     grad->b.data(),       grad->depth.data()};
  const std::vector<std::uint32_t>& offsets = state.gaussian_offsets;
  const std::vector<std::uint32_t>& entries = state.gaussian_entries;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(p.size()); ++i) {
    T sum[kPer] = {};
    for (std::uint32_t j = offsets[i]; j < offsets[i + 1]; ++j) {
      const T* e = &entry_grads[kPer * static_cast<std::size_t>(entries[j])];
      for (int f = 0; f < kPer; ++f) sum[f] += e[f];
    }
    for (int f = 0; f < kPer; ++f) fields[f][i] = sum[f];
  }
}

}  // namespace

template <typename T>
std::uint64_t RasterizeToPixelsBackward(const RasterSettingsT<T>& settings,
                                        const RasterStateT<T>& state,
                                        const RenderOutputT<T>& out,
                                        const RenderGradientsT<T>& d_out,
                                        std::vector<T>* entry_grads,
                                        ProjectedGradientsT<T>* grad) {
  const int width = state.width, height = state.height;
  const std::vector<std::uint32_t>& ids = state.sorted_ids;
  const std::vector<std::uint32_t>& ranges = state.tile_ranges;
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  const ProjectedGaussiansT<T>& p = state.projected;
  // Every entry's gradient is written below (zero where the entry did not
  // blend), so the buffer is only sized.
  entry_grads->resize(kPer * ids.size());
  std::uint64_t evaluations = 0;

  // Gaussian-major, back to front, as the forward: each Gaussian updates
  // the pixels of its box (BoxInTile) whose last contributor lies beyond it,
  // so every pixel sees the same Gaussians in reverse order as a pixel-major
  // walk would. Lane groups are branch-free loops, as in the forward; each
  // lane slot sums its share of the Gaussian's gradient over the box's
  // groups and the slots are added in a fixed order. A tile's entries are its
  // own: tiles run in parallel without sharing a gradient slot.
#pragma omp parallel for schedule(dynamic, 1) reduction(+ : evaluations)
  for (int tile = 0; tile < tiles_x * tiles_y; ++tile) {
    constexpr int kTilePixels = kTileSize * kTileSize;
    alignas(64) T t[kTilePixels], t_final[kTilePixels],
        d_acc_depth[kTilePixels], d_accumulated[kTilePixels];
    alignas(64) T dc[3][kTilePixels], behind[3][kTilePixels],
        behind_depth[kTilePixels];
    alignas(64) T lane_sum[kPer][kLaneGroup];
    alignas(64) std::uint32_t last[kTilePixels];
    const BackwardPixels<T> b{t,   t_final, d_acc_depth,  d_accumulated,
                              dc,  behind,  behind_depth, lane_sum,
                              last};
    const std::uint32_t begin = ranges[2 * tile], end = ranges[2 * tile + 1];
    const TileRect<T> rect(tile, tiles_x, width, height);
    LoadBackwardTile(settings, state, out, d_out, rect, b);
    // Entries past every pixel's last contributor blended nowhere (the
    // forward stopped before them): their gradient is zero.
    const std::uint32_t stop =
        std::max(begin, *std::max_element(last, last + kTilePixels));
    std::fill(entry_grads->begin() + kPer * static_cast<std::size_t>(stop),
              entry_grads->begin() + kPer * static_cast<std::size_t>(end),
              T(0));
    for (std::uint32_t k = stop; k-- > begin;) {
      const std::uint32_t g = ids[k];
      T* e = &(*entry_grads)[kPer * static_cast<std::size_t>(k)];
      TileBox box;
      if (!BoxInTile(p, g, rect.x_begin, rect.x_end, rect.y_begin, rect.y_end,
                     &box)) {
        std::fill(e, e + kPer, T(0));
        continue;
      }
      evaluations += static_cast<std::uint64_t>(box.y1 - box.y0 + 1) *
                     (box.group1 - box.group0 + 1) * kLaneGroup;
      BackwardGaussian(p, g, k, box, rect, b, e);
    }
  }
  SumEntryGradients(state, *entry_grads, grad);
  return evaluations;
}

namespace {

// kProbeGaussians Gaussians over tile 0 of a one-tile image: wide (alpha
// about 0.018 at the corners, above kMinAlpha) and faint (transmittance
// 0.3 after all of them, far above kMinTransmittance), so that every pair
// blends and no pixel stops.
ProjectedGaussiansT<float> ProbeGaussians() {
  ProjectedGaussiansT<float> p;
  p.Resize(kProbeGaussians);
  for (int g = 0; g < kProbeGaussians; ++g) {
    p.x[g] = 8.0f + 0.01f * g;
    p.y[g] = 8.0f - 0.01f * g;
    p.conic_a[g] = p.conic_c[g] = 1e-3f;
    p.conic_b[g] = 1e-4f;
    p.opacity[g] = 0.02f;
    p.r[g] = p.g[g] = p.b[g] = 0.5f;
    p.depth[g] = 1.0f + g;
    p.extent_x[g] = p.extent_y[g] = 64.0f;
  }
  return p;
}

// Forward pairs blended in `min_seconds` (at least one pass), and the
// sum of the outputs (kept so that the work is not optimised away).
std::uint64_t ProbeForward(const ProjectedGaussiansT<float>& p,
                           double min_seconds, float* sink) {
  const TileRect<float> rect(0, 1, kTileSize, kTileSize);
  TileBox box;
  BoxInTile(p, 0, 0, kTileSize, 0, kTileSize, &box);
  std::uint64_t pairs = 0;
  const Timer timer;
  do {
    ForwardTile<float> f(rect, 0);
    for (std::uint32_t g = 0; g < kProbeGaussians; ++g)
      f.Blend(p, g, g, box, rect);
    *sink += f.cr[0] + f.t[kTileSize * kTileSize - 1];
    pairs += kProbeGaussians * kTileSize * kTileSize;
  } while (timer.WallSeconds() < min_seconds);
  return pairs;
}

std::uint64_t ProbeBackward(const ProjectedGaussiansT<float>& p,
                            double min_seconds, float* sink) {
  constexpr int kTilePixels = kTileSize * kTileSize;
  alignas(64) float t[kTilePixels], t_final[kTilePixels],
      d_acc_depth[kTilePixels], d_accumulated[kTilePixels];
  alignas(64) float dc[3][kTilePixels], behind[3][kTilePixels],
      behind_depth[kTilePixels];
  alignas(64) float lane_sum[kPer][kLaneGroup];
  alignas(64) std::uint32_t last[kTilePixels];
  const BackwardPixels<float> b{t,   t_final, d_acc_depth,  d_accumulated,
                                dc,  behind,  behind_depth, lane_sum,
                                last};
  const TileRect<float> rect(0, 1, kTileSize, kTileSize);
  TileBox box;
  BoxInTile(p, 0, 0, kTileSize, 0, kTileSize, &box);
  float e[kPer];
  std::uint64_t pairs = 0;
  const Timer timer;
  do {
    for (int i = 0; i < kTilePixels; ++i) {
      t[i] = t_final[i] = 0.3f;
      d_acc_depth[i] = d_accumulated[i] = 1e-3f;
      behind_depth[i] = 0.0f;
      last[i] = kProbeGaussians;
      for (int c = 0; c < 3; ++c) {
        dc[c][i] = 1e-3f;
        behind[c][i] = 0.0f;
      }
    }
    for (std::uint32_t k = kProbeGaussians; k-- > 0;) {
      BackwardGaussian(p, k, k, box, rect, b, e);
      *sink += e[0] + e[5];
    }
    pairs += kProbeGaussians * kTilePixels;
  } while (timer.WallSeconds() < min_seconds);
  return pairs;
}

}  // namespace

BlendCeiling ProbeBlendCeiling(int threads, double min_seconds) {
  const ProjectedGaussiansT<float> p = ProbeGaussians();
  BlendCeiling c;
  float sink = 0;
  for (const bool forward : {true, false}) {
    std::uint64_t pairs = 0;
    const Timer timer;
#pragma omp parallel num_threads(threads) reduction(+ : pairs, sink)
    pairs += forward ? ProbeForward(p, min_seconds, &sink)
                     : ProbeBackward(p, min_seconds, &sink);
    const double rate = pairs / timer.WallSeconds();
    (forward ? c.forward_pairs_per_s : c.backward_pairs_per_s) = rate;
  }
  // An empty asm that reads `sink` keeps the compiler from dropping the
  // probes' work (what benchmark::DoNotOptimize does).
  asm volatile("" : : "r,m"(sink) : "memory");
  return c;
}

template std::uint64_t RasterizeToPixelsForward(const RasterSettingsT<float>&,
                                                RasterStateT<float>*,
                                                RenderOutputT<float>*);
template std::uint64_t RasterizeToPixelsForward(const RasterSettingsT<double>&,
                                                RasterStateT<double>*,
                                                RenderOutputT<double>*);
template std::uint64_t RasterizeToPixelsBackward(const RasterSettingsT<float>&,
                                                 const RasterStateT<float>&,
                                                 const RenderOutputT<float>&,
                                                 const RenderGradientsT<float>&,
                                                 std::vector<float>*,
                                                 ProjectedGradientsT<float>*);
template std::uint64_t RasterizeToPixelsBackward(
    const RasterSettingsT<double>&, const RasterStateT<double>&,
    const RenderOutputT<double>&, const RenderGradientsT<double>&,
    std::vector<double>*, ProjectedGradientsT<double>*);

}  // namespace pano4d
