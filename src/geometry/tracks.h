#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace pano4d {

// 2D point tracks from dense optical flow (OpenCV DIS, down to full
// resolution) chained frame to frame, forward and backward from a reference
// frame, with a forward-backward check at every link: a track ends where the
// flow to the next frame and back misses its start by more than the threshold
// (occlusion, or flow that cannot be trusted). The blueprint's motion
// initialisation lifts these with depth.
struct TrackOptions {
  // A link fails when flow there and back misses by more than this many
  // pixels.
  double consistency_threshold = 1.0;
  // Tracks also end where they leave the image.
  void Check() const;  // throws pano4d::Error naming the field
};

struct Tracks2D {
  int num_times = 0;
  int reference_time = 0;
  // Per track and time (track-major, T entries per track): pixel position
  // (continuous, pixel centres at +0.5) and whether it is valid there.
  std::vector<Eigen::Vector2f> pixels;
  std::vector<std::uint8_t> valid;
  std::size_t size() const {
    return num_times == 0 ? 0 : valid.size() / num_times;
  }
  const Eigen::Vector2f& pixel(std::size_t track, int t) const {
    return pixels[track * num_times + t];
  }
  bool is_valid(std::size_t track, int t) const {
    return valid[track * num_times + t] != 0;
  }
};

// One link of a chain: dense flow from time `from` to time `to` (CV_32FC2,
// pixels), and either the flow back (`backward`: a link holds where the
// two miss by at most the consistency threshold) or a mask of where the
// forward flow is trusted (`valid`, CV_8UC1, nonzero = trusted; a learned
// flow's occlusion mask).
struct FlowLink {
  int from = 0, to = 0;
  cv::Mat forward, backward, valid;
};

// Chains `seeds` (pixels at `reference`) along `links` over `num_times`
// times: each link extends the tracks valid at its `from`, so links must
// come in order away from the reference (reference -> reference + 1 -> ...
// and reference -> reference - 1 -> ...). A missing link breaks the tracks
// there. Throws pano4d::Error for a reference outside the times.
Tracks2D ChainTracks(int num_times, int reference,
                     const std::vector<Eigen::Vector2f>& seeds,
                     const std::vector<FlowLink>& links,
                     const TrackOptions& options = {});

// `frames` holds one image per time (8-bit or float in [0, 1], 1 or 3
// channels, all one size); an empty Mat is a time without a frame, where
// every track breaks. `seeds` are pixels of the reference frame. Throws
// pano4d::Error for a reference without a frame or mismatched sizes.
Tracks2D ChainFlowTracks(const std::vector<cv::Mat>& frames, int reference,
                         const std::vector<Eigen::Vector2f>& seeds,
                         const TrackOptions& options = {});

}  // namespace pano4d
