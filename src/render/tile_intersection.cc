#include "src/render/tile_intersection.h"

#include <cstring>
#include <string>

#include "src/core/error.h"

namespace pano4d {

template <typename T>
void IntersectTiles(const ProjectedGaussiansT<T>& p, int width, int height,
                    TileSortBuffers* buffers,
                    std::vector<std::uint32_t>* sorted_ids,
                    std::vector<std::uint32_t>* tile_ranges) {
  const std::size_t n = p.size();
  const int tiles_x = (width + kTileSize - 1) / kTileSize;
  const int tiles_y = (height + kTileSize - 1) / kTileSize;
  std::vector<std::uint32_t>& offsets = buffers->offsets;
  std::vector<std::uint64_t>& keys = buffers->keys;
  std::vector<std::uint32_t>& ids = *sorted_ids;

  offsets.resize(n + 1);
  offsets[0] = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t count =
        p.radius[i] > 0
            ? static_cast<std::uint64_t>(p.tile_x1[i] - p.tile_x0[i]) *
                  (p.tile_y1[i] - p.tile_y0[i])
            : 0;
    if (offsets[i] + count > UINT32_MAX) {
      throw Error("rasterizer", "tile entries",
                  std::to_string(offsets[i] + count),
                  "more than 2^32 (Gaussian, tile) pairs");
    }
    offsets[i + 1] = static_cast<std::uint32_t>(offsets[i] + count);
  }
  const std::uint32_t total = offsets[n];
  keys.resize(total);
  ids.resize(total);
  // Key: tile in the high 32 bits, the depth's float bits (monotonic for
  // positive floats) in the low 32; the Gaussian index breaks ties, so the
  // order is total and the same whatever the threads.
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    if (p.radius[i] == 0) continue;
    // The float's bits, whatever T is: the key has 32 bits for depth.
    const float depth = static_cast<float>(p.depth[i]);
    std::uint32_t depth_bits;
    std::memcpy(&depth_bits, &depth, sizeof(depth_bits));
    std::uint32_t k = offsets[i];
    for (int ty = p.tile_y0[i]; ty < p.tile_y1[i]; ++ty) {
      for (int tx = p.tile_x0[i]; tx < p.tile_x1[i]; ++tx) {
        keys[k] =
            (static_cast<std::uint64_t>(ty * tiles_x + tx) << 32) | depth_bits;
        ids[k] = static_cast<std::uint32_t>(i);
        ++k;
      }
    }
  }
  // LSD radix sort of the (key, id) pairs on the key, 8 bits a pass, over
  // the bits the keys use (32 of depth, then the tile). Radix sort is
  // stable and the entries were written in Gaussian order, so equal keys
  // keep index order: the order is total, as the rasterization and its
  // backward need.
  const std::uint64_t tiles = static_cast<std::uint64_t>(tiles_x) * tiles_y;
  int key_bits = 32;
  while ((std::uint64_t{1} << (key_bits - 32)) < tiles) ++key_bits;
  buffers->key_scratch.resize(total);
  buffers->id_scratch.resize(total);
  for (int shift = 0; shift < key_bits; shift += 8) {
    std::uint32_t count[257] = {};
    for (std::uint32_t k = 0; k < total; ++k)
      ++count[((keys[k] >> shift) & 0xff) + 1];
    for (int d = 0; d < 256; ++d) count[d + 1] += count[d];
    for (std::uint32_t k = 0; k < total; ++k) {
      const std::uint32_t slot = count[(keys[k] >> shift) & 0xff]++;
      buffers->key_scratch[slot] = keys[k];
      buffers->id_scratch[slot] = ids[k];
    }
    keys.swap(buffers->key_scratch);
    ids.swap(buffers->id_scratch);
  }
  std::vector<std::uint32_t>& ranges = *tile_ranges;
  ranges.assign(2 * tiles, 0);
  for (std::uint32_t k = 0; k < total; ++k) {
    const std::uint32_t tile = static_cast<std::uint32_t>(keys[k] >> 32);
    if (k == 0 || static_cast<std::uint32_t>(keys[k - 1] >> 32) != tile)
      ranges[2 * tile] = k;
    ranges[2 * tile + 1] = k + 1;
  }
}

template void IntersectTiles(const ProjectedGaussiansT<float>&, int, int,
                             TileSortBuffers*, std::vector<std::uint32_t>*,
                             std::vector<std::uint32_t>*);
template void IntersectTiles(const ProjectedGaussiansT<double>&, int, int,
                             TileSortBuffers*, std::vector<std::uint32_t>*,
                             std::vector<std::uint32_t>*);

}  // namespace pano4d
