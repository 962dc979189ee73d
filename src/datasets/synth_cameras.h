#pragma once

#include <cstdint>
#include <vector>

#include "src/core/posed_camera.h"
#include "src/datasets/synth_scene.h"

namespace pano4d::synth {

// An OpenCV-convention camera at `eye` looking at `target`, world z up.
PosedCamera LookAt(const Camera& intrinsics, const Eigen::Vector3d& eye,
                   const Eigen::Vector3d& target);

// The monocular training video: a handheld-like arc on the -y side of the
// scene (the layout's sweep, height and radius around the target; 56
// degrees by default), facing inwards, with smooth sway of a few
// centimetres in position and aim.
std::vector<PosedCamera> TrainingTrajectory(const Scene& scene,
                                            const Camera& intrinsics,
                                            int frames, std::uint32_t seed);

// DyCheck-like validation cameras 1 and 2: static, at ValidationEye (by
// default 75 degrees of azimuth to either side of the training arc's
// middle, one lower and one higher), so that part of what they see was
// never in the training video.
PosedCamera ValidationCamera(const Scene& scene, const Camera& intrinsics,
                             int index);

}  // namespace pano4d::synth
