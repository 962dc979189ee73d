#pragma once
// The rasterizer's second stage (gsplat's `isect_tiles`): every (tile,
// Gaussian) pair the projection's tile ranges name, sorted by tile and
// depth. It has no backward: the order is piecewise constant.
#include <cstdint>
#include <vector>

#include "src/render/rasterizer.h"

namespace pano4d {

// Fills state's sorted_ids (the Gaussian of each pair, by tile, then depth,
// then index: a total order, the same whatever the threads), tile_ranges
// ([begin, end) into sorted_ids per tile of its width x height image, 2 per
// tile) and their inverse, gaussian_offsets and gaussian_entries, from its
// projected Gaussians. Throws pano4d::Error beyond 2^32 pairs.
template <typename T>
void IntersectTiles(TileSortBuffers* buffers, RasterStateT<T>* state);

}  // namespace pano4d
