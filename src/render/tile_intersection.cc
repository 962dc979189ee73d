#include "src/render/tile_intersection.h"

#include <algorithm>
#include <cstring>
#include <string>

#include <omp.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

// The float's bits, whatever T is: monotonic in the depth for the positive
// depths the projection keeps.
template <typename T>
std::uint32_t DepthBits(T depth) {
  const float d = static_cast<float>(depth);
  std::uint32_t bits;
  std::memcpy(&bits, &d, sizeof(bits));
  return bits;
}

// The visible Gaussians in index order with their depth keys into
// `buffers`, and each Gaussian's first entry (offsets, n + 1 of them: the
// last is the total). Throws pano4d::Error past 2^32 entries.
template <typename T>
std::uint32_t ListVisible(const ProjectedGaussiansT<T>& p,
                          TileSortBuffers* buffers,
                          std::vector<std::uint32_t>* offsets) {
  const std::size_t n = p.size();
  std::vector<std::uint32_t>& order = buffers->order;
  std::vector<std::uint32_t>& keys = buffers->keys;
  order.clear();
  keys.clear();
  offsets->resize(n + 1);
  std::uint64_t total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    (*offsets)[i] = static_cast<std::uint32_t>(total);
    if (p.radius[i] == 0) continue;
    order.push_back(static_cast<std::uint32_t>(i));
    keys.push_back(DepthBits(p.depth[i]));
    total += static_cast<std::uint64_t>(p.tile_x1[i] - p.tile_x0[i]) *
             (p.tile_y1[i] - p.tile_y0[i]);
    if (total > UINT32_MAX) {
      throw Error("rasterizer", "tile entries", std::to_string(total),
                  "more than 2^32 (Gaussian, tile) pairs");
    }
  }
  (*offsets)[n] = static_cast<std::uint32_t>(total);
  return static_cast<std::uint32_t>(total);
}

// LSD radix sort of buffers' order by its keys, the 32 depth bits, 8 a
// pass (stable: equal depths keep index order).
void RadixSortByDepth(TileSortBuffers* buffers) {
  std::vector<std::uint32_t>& order = buffers->order;
  std::vector<std::uint32_t>& keys = buffers->keys;
  const std::size_t visible = order.size();
  buffers->order_scratch.resize(visible);
  buffers->key_scratch.resize(visible);
  for (int shift = 0; shift < 32; shift += 8) {
    std::uint32_t count[257] = {};
    for (std::size_t k = 0; k < visible; ++k)
      ++count[((keys[k] >> shift) & 0xff) + 1];
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (std::size_t k = 0; k < visible; ++k) {
      const std::uint32_t slot = count[(keys[k] >> shift) & 0xff]++;
      buffers->key_scratch[slot] = keys[k];
      buffers->order_scratch[slot] = order[k];
    }
    keys.swap(buffers->key_scratch);
    order.swap(buffers->order_scratch);
  }
}

// Each tile's range of entries: per tile, the runs' counts one after
// another (cursors[tiles * run + tile] becomes the run's first position).
void TileRanges(std::size_t tiles, int threads,
                std::vector<std::uint32_t>* cursors,
                std::vector<std::uint32_t>* ranges) {
  std::uint32_t begin = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    (*ranges)[2 * t] = begin;
    for (int run = 0; run < threads; ++run) {
      const std::uint32_t count = (*cursors)[tiles * run + t];
      (*cursors)[tiles * run + t] = begin;
      begin += count;
    }
    (*ranges)[2 * t + 1] = begin;
  }
}

}  // namespace

// The visible Gaussians are sorted once by (depth, index) with an LSD radix
// sort (stable, so equal depths keep index order), then dealt to their
// tiles in that order: each tile's list comes out sorted by depth without
// sorting the (Gaussian, tile) pairs themselves.
template <typename T>
void IntersectTiles(TileSortBuffers* buffers, RasterStateT<T>* state) {
  const ProjectedGaussiansT<T>& p = state->projected;
  const int width = state->width, height = state->height;
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  const std::size_t tiles = static_cast<std::size_t>(tiles_x) * tiles_y;
  std::vector<std::uint32_t>& offsets = state->gaussian_offsets;
  const std::uint32_t total = ListVisible(p, buffers, &offsets);
  RadixSortByDepth(buffers);
  const std::vector<std::uint32_t>& order = buffers->order;
  const std::size_t visible = order.size();

  // The sorted Gaussians' tile rectangles, packed for the passes below.
  std::vector<TileSortBuffers::Rect>& rects = buffers->rects;
  rects.resize(visible);
  for (std::size_t k = 0; k < visible; ++k) {
    const std::uint32_t g = order[k];
    rects[k] = {p.tile_x0[g], p.tile_x1[g], p.tile_y0[g], p.tile_y1[g], g,
                offsets[g]};
  }

  // A parallel counting sort by tile that keeps the depth order: thread t
  // takes the t-th run of the sorted Gaussians, counts its entries per
  // tile, and deals them after those of the runs before it, so each tile's
  // list is in depth order, the same whatever the threads.
  std::vector<std::uint32_t>& ranges = state->tile_ranges;
  std::vector<std::uint32_t>& cursors = buffers->cursor;
  std::vector<std::uint32_t>& ids = state->sorted_ids;
  std::vector<std::uint32_t>& entries = state->gaussian_entries;
  ranges.resize(2 * tiles);
  ids.resize(total);
  entries.resize(total);
#pragma omp parallel
  {
    const int threads = omp_get_num_threads(), thread = omp_get_thread_num();
#pragma omp single
    cursors.assign(tiles * threads, 0);
    const std::size_t k0 = visible * thread / threads;
    const std::size_t k1 = visible * (thread + 1) / threads;
    std::uint32_t* cursor = &cursors[tiles * thread];
    for (std::size_t k = k0; k < k1; ++k) {
      const TileSortBuffers::Rect& r = rects[k];
      for (int ty = r.y0; ty < r.y1; ++ty) {
        std::uint32_t* row = cursor + static_cast<std::size_t>(ty) * tiles_x;
        for (int tx = r.x0; tx < r.x1; ++tx) ++row[tx];
      }
    }
#pragma omp barrier
#pragma omp single
    TileRanges(tiles, threads, &cursors, &ranges);
    for (std::size_t k = k0; k < k1; ++k) {
      const TileSortBuffers::Rect& r = rects[k];
      const int tile_width = r.x1 - r.x0;
      for (int ty = r.y0; ty < r.y1; ++ty) {
        std::uint32_t* row = cursor + static_cast<std::size_t>(ty) * tiles_x;
        std::uint32_t* own = &entries[r.offset + (ty - r.y0) * tile_width];
        for (int tx = r.x0; tx < r.x1; ++tx) {
          const std::uint32_t position = row[tx]++;
          ids[position] = r.g;
          own[tx - r.x0] = position;
        }
      }
    }
  }
}

template void IntersectTiles(TileSortBuffers*, RasterStateT<float>*);
template void IntersectTiles(TileSortBuffers*, RasterStateT<double>*);

}  // namespace pano4d
