#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "src/core/posed_camera.h"
#include "src/datasets/synth_scene.h"

namespace pano4d::synth {

// An OpenCV-convention camera at `eye` looking at `target`, world z up.
PosedCamera LookAt(const Camera& intrinsics, const Eigen::Vector3d& eye,
                   const Eigen::Vector3d& target);

// How the training camera moves, for casual-video cases SfM finds hard.
enum class TrainingMotion {
  kArc,            // the layout's arc (56 degrees by default)
  kSlowArc,        // the same arc's middle eighth: little parallax
  kPan,            // a fixed centre at the arc's middle, turning: no parallax
  kStatic,         // one fixed camera at the arc's middle (sway and all)
  kHandheldStill,  // held still by hand at the arc's middle: drift, tremor
};
// "arc", "slow-arc", "pan", "static-camera", "handheld-still"; FromName
// throws pano4d::Error
// for another name.
const char* TrainingMotionName(TrainingMotion motion);
TrainingMotion TrainingMotionFromName(const std::string& name);

// The monocular training video: a handheld-like arc on the -y side of the
// scene (the layout's sweep, height and radius around the target), facing
// inwards, with smooth sway of a few centimetres in position and aim; or
// the slow arc, pan or static camera of `motion` at the arc's middle. A
// pan turns the aim through the arc's sweep about the eye, which stays
// where it is (no sway in position: a pure rotation); a static camera has
// neither sway; a camera held still by hand drifts by a tenth of the arc's
// sway and trembles from frame to frame (seeded, a few millimetres at the
// target): flow of about a pixel, below what tells a moving camera.
std::vector<PosedCamera> TrainingTrajectory(
    const Scene& scene, const Camera& intrinsics, int frames,
    std::uint32_t seed, TrainingMotion motion = TrainingMotion::kArc);

// DyCheck-like validation cameras 1 and 2: static, at ValidationEye (by
// default 75 degrees of azimuth to either side of the training arc's
// middle, one lower and one higher), so that part of what they see was
// never in the training video.
PosedCamera ValidationCamera(const Scene& scene, const Camera& intrinsics,
                             int index);

}  // namespace pano4d::synth
