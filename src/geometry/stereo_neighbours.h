#pragma once

// What plane-sweep stereo (stereo.h) is given for a frame: the other frames
// it is matched against, and the depths it sweeps over, both from the
// cameras and the sparse SfM points.

#include <cstddef>
#include <optional>
#include <vector>

#include "src/core/posed_camera.h"

namespace pano4d {

struct StereoNeighbourOptions {
  // At most this many neighbours per frame ...
  std::size_t neighbours = 4;
  // ... those whose baseline / the frame's median depth is nearest this
  // ratio (wide enough to resolve depth, narrow enough to match), ...
  double baseline_ratio = 0.08;
  // ... at least this ratio (a nearly identical view resolves nothing), ...
  double min_baseline_ratio = 0.01;
  // ... and looking within this angle of the frame's viewing direction.
  double max_angle_degrees = 35.0;
  void Check() const;  // throws pano4d::Error naming the field
};

// The indices into `cameras` of the neighbours of cameras[reference], best
// first (|log(ratio / baseline_ratio)| ascending); none when no camera
// qualifies. `median_depth` > 0 is the reference frame's.
std::vector<std::size_t> SelectStereoNeighbours(
    const std::vector<PosedCamera>& cameras, std::size_t reference,
    double median_depth, const StereoNeighbourOptions& options = {});

// A frame's sweep range from the z-depths of the sparse points it sees.
struct StereoRange {
  double near = 0.0, far = 0.0;  // what the sweep covers
  double median = 0.0;           // the points' median depth
};

// Fewer sparse points than this say nothing about a frame's range.
inline constexpr std::size_t kMinStereoPoints = 20;
// The sweep covers the points' 2nd to 98th percentile widened by these
// factors: the points are sparse, and the surfaces between them may lie a
// little nearer or farther.
inline constexpr double kStereoNearMargin = 0.7;
inline constexpr double kStereoFarMargin = 1.5;

// The range of the points at depths `z` (any order); nothing when there
// are fewer than kMinStereoPoints.
std::optional<StereoRange> StereoRangeOf(std::vector<double> z);

}  // namespace pano4d
