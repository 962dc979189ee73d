#pragma once

// The rotation-only model of a COLMAP workspace: for a camera that turns
// about a fixed centre (a pan) or stands still, where the mapper has
// nothing to triangulate. The estimate is src/geometry/rotation_only.h's,
// from the database's verified matches; the model has one centre and no
// points.

#include <filesystem>

#include "colmap_ext/model.h"

namespace pano4d {

// When nearly every verified pair of `database` fits a homography and
// rotations alone explain the matches, writes the rotation-only model to
// `out` (binary; one PINHOLE camera per database camera, every centre at
// the origin) and returns true; otherwise returns false, having logged
// why. `width` x `height` is the frames' size.
bool TryRotationOnlyModel(const std::filesystem::path& database, int width,
                          int height, const std::filesystem::path& out);

// A model whose cameras share one centre and that has no points (COLMAP's
// mapper never writes one).
bool IsRotationOnly(const ColmapModel& model);
// A rotation-only model whose rotations all agree: a still camera.
bool IsStaticCamera(const ColmapModel& model);

}  // namespace pano4d
