#pragma once
// The rasterizer's second stage (gsplat's `isect_tiles`): every (tile,
// Gaussian) pair the projection's tile ranges name, sorted by tile and
// depth. It has no backward: the order is piecewise constant.
#include <cstdint>
#include <vector>

#include "src/render/rasterizer.h"

namespace pano4d {

// Writes *sorted_ids (the Gaussian of each pair, by tile, then depth, then
// index: a total order, the same whatever the threads) and *tile_ranges
// ([begin, end) into sorted_ids per tile of a width x height image, 2 per
// tile). Throws pano4d::Error beyond 2^32 pairs.
template <typename T>
void IntersectTiles(const ProjectedGaussiansT<T>& projected, int width,
                    int height, TileSortBuffers* buffers,
                    std::vector<std::uint32_t>* sorted_ids,
                    std::vector<std::uint32_t>* tile_ranges);

}  // namespace pano4d
