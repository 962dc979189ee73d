#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace pano4d {

// Masks of the pixels that move independently of the camera, so that SfM
// (COLMAP) extracts no features there. Per frame, dense optical flow to
// neighbouring frames is tested against the two-view geometry of each pair:
// a fundamental matrix by LMedS; a homography where the camera only rotates
// or the scene is too flat for a fundamental matrix to be defined; the
// identity where the camera stands still. Lengths are fractions of the image
// diagonal and flow is computed at a fixed working size, so the same video at
// another resolution gives about the same masks.
struct DynamicMaskOptions {
  // Frame t is compared with frames t - gap and t + gap, for each gap, where
  // they exist: small gaps see fast motion before the flow breaks, large
  // ones slow motion that small gaps cannot tell from noise. Positive, unique.
  std::vector<int> frame_gaps = {1, 2, 4};
  // A camera held still (the median flow between consecutive frames below
  // static_motion_threshold, sampled over the video) also compares frames
  // these many frames apart: its background stays in view and in place, so
  // long gaps cost no occlusion and add the votes that find a slow subject
  // (the temporal accumulation a still camera needs). Positive.
  std::vector<int> still_camera_gaps = {8, 16};
  // Flow is computed on frames resampled (up or down) so that their longer
  // side has this many pixels: bounded time, and flow noise in working
  // pixels that does not depend on the input size.
  int working_long_side = 512;
  // A pixel violates the geometry towards a neighbour when its residual (the
  // Sampson distance to the epipolar line, or the homography's transfer
  // error) exceeds this fraction of the diagonal (0.0025 = 1.6 px at
  // 512x384), ...
  double residual_threshold = 0.0025;
  // ... or this many robust standard deviations of the pair's LMedS
  // residuals, if more: noisier flow (a wide baseline, blur) needs a wider
  // margin.
  double noise_factor = 3.0;
  // Flow to a neighbour and back must return within this fraction of the
  // diagonal; otherwise the pixel is occluded there or its flow is
  // unreliable, and that neighbour does not vote on it.
  double consistency_threshold = 0.006;
  // A pixel is dynamic when at least this fraction of the neighbours that
  // vote on it (rounded up), and at least two when two vote, see a
  // violation: an occlusion or a flow error fools one neighbour, a moving
  // object fools most.
  double agreement = 0.5;
  // Correspondences for the two-view models: one per grid cell of this many
  // working pixels (LMedS time grows with their number).
  int grid_step = 16;
  // Fewer consistent grid correspondences than this, or fewer inliers than
  // min_inlier_ratio of them: the pair says nothing (a cut, heavy blur, a
  // blank wall).
  int min_correspondences = 50;
  double min_inlier_ratio = 0.25;
  // LMedS confidence (cv::findFundamentalMat, cv::findHomography).
  double lmeds_confidence = 0.99;
  // The median flow of the grid below this fraction of the diagonal: the
  // camera stands still, the flow magnitude itself is the residual.
  double static_motion_threshold = 0.002;
  // The homography replaces the fundamental matrix when its inlier ratio is
  // at most this much below the fundamental matrix's: the scene shows too
  // little parallax for the epipolar geometry to be trusted.
  double homography_margin = 0.02;
  // Clean-up radii (fractions of the diagonal): opening removes speckle,
  // closing fills holes inside objects, dilation adds a safety margin since
  // a feature on an object's border is as harmful as one inside it.
  double opening_radius = 0.004;
  double closing_radius = 0.015;
  double dilation_radius = 0.01;
  // The margin for a camera held still: the masks of such a video serve the
  // fit more than SfM (no parallax for the mapper to protect), and the fit
  // loses whatever the margin marks.
  double still_camera_dilation_radius = 0.0075;

  // Throws pano4d::Error naming the wrong field.
  void Check() const;
};

struct DynamicMaskFrameStats {
  double dynamic_fraction = 0.0;  // of the frame's pixels, after clean-up
  int neighbours = 0;             // neighbours that exist in the video
  int neighbours_used = 0;        // of those, with a usable two-view model
  // Mean over the used neighbours of the fraction of grid correspondences
  // that agree with the model; 0 when none was used.
  double inlier_ratio = 0.0;
  // Some neighbour was judged by flow magnitude (the camera stood still) or
  // by a homography (it only rotated, or the scene was flat).
  bool static_camera = false;
  bool homography = false;
};

struct DynamicMaskStats {
  std::vector<DynamicMaskFrameStats> frames;
  // The camera was held still: still_camera_gaps and
  // still_camera_dilation_radius applied.
  bool held_still = false;
  double seconds = 0.0;  // wall time of ComputeDynamicMasks

  double MeanDynamicFraction() const;
  // One line for logs: frames, mean and max dynamic fraction, frames judged
  // with the static-camera or homography fallback or without any usable
  // neighbour, whether the camera was held still, time.
  std::string BriefReport() const;
};

// One CV_8UC1 mask per frame, of the frame's size, 255 = dynamic. A video
// whose camera is held still is judged with the options' still_camera_*
// settings (stats->held_still says so). Frames are
// 8-bit, 16-bit or float (in [0, 1]) with 1, 3 or 4 channels, all of one
// size (channel order only weighs the grey conversion, so RGB works too).
// A single frame gives an all-static mask (nothing to compare with); no
// frames give no masks. Throws pano4d::Error naming the frame that is empty,
// of another size or of an unsupported type.
std::vector<cv::Mat> ComputeDynamicMasks(const std::vector<cv::Mat>& frames,
                                         const DynamicMaskOptions& options = {},
                                         DynamicMaskStats* stats = nullptr);

}  // namespace pano4d
