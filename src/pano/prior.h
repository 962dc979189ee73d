#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "src/render/gaussians.h"

namespace pano4d {

// One expanded trajectory (a direction m at step e, over time) handed to a
// prior: warped frames with holes, what to generate, and the geometry.
struct PriorClip {
  std::string name;                   // e.g. "step2_dir3": messages and folders
  std::vector<cv::Mat> frames;        // CV_32FC3 RGB in [0, 1]; holes arbitrary
  std::vector<cv::Mat> masks;         // CV_8UC1: 255 = generate, 0 = keep
  std::vector<cv::Mat> depth;         // CV_32FC1 z at the target, 0 = none
  std::vector<RasterCamera> cameras;  // the target cameras, one per frame
  std::vector<int> times;             // frame time of each frame
  // The source video at the same times (what a video model conditions on).
  std::vector<cv::Mat> references;  // CV_32FC3 RGB in [0, 1]
  std::vector<RasterCamera> reference_cameras;
  // Optional (empty, or one per frame): CV_8UC1, 255 where a known pixel
  // shows a moving object at that frame's time. What moves is somewhere
  // else at the clip's other times, so the geometry prior neither copies it
  // across time nor inpaints from it.
  std::vector<cv::Mat> moving;
  // Optional (empty, or one per frame): the scene's layout proxy
  // (src/pano/layout.h) seen from each frame's camera: z-depth (CV_32FC1,
  // 0 = the ray meets none) and colour (CV_32FC3). Where a hole's content
  // comes from nothing the clip saw, the geometry prior places it on this
  // surface and fades its colour toward the surface's.
  std::vector<cv::Mat> layout_depth;
  std::vector<cv::Mat> layout_rgb;

  // Throws pano4d::Error naming the field when counts, sizes or types
  // disagree (every per-frame vector has frames.size() entries, all of the
  // cameras' sizes).
  void Check() const;
};

// What a prior gives back: every frame with its masked pixels filled
// (CV_32FC3, [0, 1], finite) and, where the prior knows it, the depth of
// what it filled (CV_32FC1, 0 = unknown; may be empty).
struct PriorResult {
  std::vector<cv::Mat> frames;
  std::vector<cv::Mat> depth;
  std::string prior;  // the name of the prior that produced it
  std::string note;   // e.g. why a fallback was used; empty when none
};

class Prior {
 public:
  virtual ~Prior() = default;
  virtual std::string name() const = 0;
  // Fills the clip's masked pixels. Unmasked pixels come back unchanged.
  // Throws pano4d::Error when it cannot.
  virtual PriorResult Fill(const PriorClip& clip) = 0;
};

// The share of a frame's larger side over which inpainted colour fades to
// the layout's (weight exp(-distance / (share x side)) on Telea's): a few
// pixels from the hole's edge Telea continues what it sees; deeper in, it
// smears edge colours over a surface it knows nothing of.
inline constexpr double kLayoutFadeShare = 0.05;

// The CPU default, with no model weights: geometry first, then classical
// inpainting, consistent over time.
//  1. Content seen at other times: each frame's holes are filled from the
//     known static pixels (not `moving`) of the clip's other frames
//     (nearest in time first), forward-warped with their depth into its
//     camera.
//  2. What nothing saw: a reference frame (the middle one) is inpainted
//     (cv::inpaint, Telea), colour and depth, from its static pixels, and
//     its filled pixels are warped into the other frames, so that the same
//     invented content appears at every time.
//  3. What is still empty is inpainted per frame, from its static pixels.
// Where the clip has a layout, inpainted content lies no nearer than the
// layout's surface, and its colour fades from the inpainted one at the
// hole's edge to the surface's within kLayoutFadeShare of the frame's size.
class GeometryPrior : public Prior {
 public:
  std::string name() const override { return "geometry"; }
  PriorResult Fill(const PriorClip& clip) override;
};

// The time one clip may take in a prior command (--prior-timeout): video
// diffusion models on a GPU take a few minutes for a clip of tens of
// frames; half an hour leaves room for a slow GPU or a first run that
// loads its weights, and still ends a command that hangs.
inline constexpr double kPriorTimeoutSeconds = 1800.0;

// The external-command plug-in for video diffusion models. `command` holds
// {in} and {out}, replaced by folder paths (shell-quoted). {in} gets:
//   frames/00000.png ...     the warped frames (8-bit RGB PNG)
//   masks/00000.png ...      255 = generate, 0 = keep
//   references/00000.png ... the source frames at the same times
//   meta.json                count, width, height, times, cameras (as
//                            CameraToJson), reference_cameras, clip name
// The command must write {out}/frames/00000.png ... : the same count and
// size, 8 or 16-bit RGB. Anything else (a non-zero exit, a missing, extra-
// short or wrongly sized frame, a file that does not decode, a command
// still running after `timeout_seconds`, which is then stopped with all it
// started) is logged as an error naming the command and the problem, and
// `fallback` fills the clip instead (result.note says why); the work folder
// is kept for inspection. The command runs in its own process group:
// Ctrl-C stops it and then pano4d (src/core/subprocess.h).
class CommandPrior : public Prior {
 public:
  CommandPrior(std::string command, std::filesystem::path work_dir,
               std::unique_ptr<Prior> fallback,
               double timeout_seconds = kPriorTimeoutSeconds);
  std::string name() const override { return "command"; }
  PriorResult Fill(const PriorClip& clip) override;

 private:
  std::string command_;
  std::filesystem::path work_dir_;
  std::unique_ptr<Prior> fallback_;
  double timeout_seconds_;
};

// The prior the expansion fills holes with: the external command when given
// (its work folders under `work_dir`), falling back to the CPU geometry
// prior when it fails; the CPU prior alone when `command` is empty.
std::unique_ptr<Prior> MakePrior(const std::string& command,
                                 const std::filesystem::path& work_dir,
                                 double timeout_seconds = kPriorTimeoutSeconds);

// V_refined = M * filled + (1 - M) * warped, per frame (M: 255 = filled).
cv::Mat Composite(const cv::Mat& warped, const cv::Mat& filled,
                  const cv::Mat& mask);

}  // namespace pano4d
