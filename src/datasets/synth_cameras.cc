#include "src/datasets/synth_cameras.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "src/core/error.h"

namespace pano4d::synth {
namespace {

constexpr double kDegrees = M_PI / 180.0;
constexpr double kTrainingAzimuth = -90.0;  // the arc's middle, degrees

// A smooth, seeded sway: a sum of three sinusoids per axis.
Eigen::Vector3d Sway(double s, double amplitude, std::mt19937& rng_seeded,
                     std::uint32_t salt) {
  std::mt19937 rng(rng_seeded() ^ salt);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI), freq(0.5, 2.5);
  Eigen::Vector3d out = Eigen::Vector3d::Zero();
  for (int axis = 0; axis < 3; ++axis) {
    for (int k = 0; k < 3; ++k) {
      out(axis) += amplitude / (k + 1) *
                   std::sin(2 * M_PI * freq(rng) * (k + 1) * s + phase(rng));
    }
  }
  return out;
}

}  // namespace

PosedCamera LookAt(const Camera& intrinsics, const Eigen::Vector3d& eye,
                   const Eigen::Vector3d& target) {
  const Eigen::Vector3d forward = (target - eye).normalized();
  const Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (!(right.norm() > 1e-9)) {
    throw Error("synth camera", "target", "",
                "cannot look straight up or down");
  }
  Eigen::Matrix3d world_from_cam;
  world_from_cam.col(0) = right.normalized();
  world_from_cam.col(2) = forward;
  world_from_cam.col(1) = forward.cross(world_from_cam.col(0));  // down
  const Eigen::Matrix3d cam_from_world = world_from_cam.transpose();
  return PosedCamera{intrinsics,
                     Rigid3d(Eigen::Quaterniond(cam_from_world).normalized(),
                             -(cam_from_world * eye))};
}

const char* TrainingMotionName(TrainingMotion motion) {
  switch (motion) {
    case TrainingMotion::kArc:
      return "arc";
    case TrainingMotion::kSlowArc:
      return "slow-arc";
    case TrainingMotion::kPan:
      return "pan";
    case TrainingMotion::kStatic:
      return "static-camera";
    case TrainingMotion::kHandheldStill:
      return "handheld-still";
  }
  return "arc";
}

TrainingMotion TrainingMotionFromName(const std::string& name) {
  for (const TrainingMotion m :
       {TrainingMotion::kArc, TrainingMotion::kSlowArc, TrainingMotion::kPan,
        TrainingMotion::kStatic, TrainingMotion::kHandheldStill}) {
    if (name == TrainingMotionName(m)) return m;
  }
  throw Error("synth", "--trajectory", name,
              "expected arc, slow-arc, pan, static-camera or handheld-still");
}

std::vector<PosedCamera> TrainingTrajectory(const Scene& scene,
                                            const Camera& intrinsics,
                                            int frames, std::uint32_t seed,
                                            TrainingMotion motion) {
  // The slow arc sweeps an eighth of the arc: at the default 56 degrees,
  // 7 degrees, about the parallax of a slow handheld step.
  constexpr double kSlowArcShare = 1.0 / 8;
  // A hand holding the camera still: a tenth of the arc's drift, and a
  // tremor of 3 mm at the target (0.06 degrees, half a pixel at 480x360).
  constexpr double kHandheldDriftShare = 1.0 / 10;
  constexpr double kTremorMetres = 0.003;
  std::mt19937 tremor_rng(seed * 31U + 13U);
  std::normal_distribution<double> tremor(0.0, kTremorMetres);
  const Layout& l = scene.layout;
  const auto eye_at = [&](double azimuth_degrees) {
    const double a = azimuth_degrees * kDegrees;
    return Eigen::Vector3d(scene.target.x() + l.training_radius * std::cos(a),
                           scene.target.y() + l.training_radius * std::sin(a),
                           l.training_height);
  };
  std::vector<PosedCamera> cameras;
  cameras.reserve(frames);
  for (int t = 0; t < frames; ++t) {
    const double s = frames > 1 ? static_cast<double>(t) / (frames - 1) : 0.0;
    // Each sway draws from its own generator seeded identically per frame,
    // so the path is a smooth function of s.
    std::mt19937 position_rng(seed * 31U + 7U), aim_rng(seed * 31U + 11U);
    const Eigen::Vector3d position_sway = Sway(s, 0.03, position_rng, 1);
    const Eigen::Vector3d aim_sway = Sway(s, 0.06, aim_rng, 2);
    const double sweep = l.training_half_sweep_degrees * (2 * s - 1);
    switch (motion) {
      case TrainingMotion::kArc:
      case TrainingMotion::kSlowArc: {
        const double share = motion == TrainingMotion::kArc ? 1 : kSlowArcShare;
        cameras.push_back(LookAt(
            intrinsics,
            eye_at(kTrainingAzimuth + share * sweep) + share * position_sway,
            scene.target + aim_sway));
        break;
      }
      case TrainingMotion::kPan: {
        // The eye stays; the aim turns about it through the arc's sweep.
        const Eigen::Vector3d eye = eye_at(kTrainingAzimuth);
        const Eigen::Vector3d ahead = scene.target + aim_sway - eye;
        const Eigen::Vector3d turned =
            Eigen::AngleAxisd(sweep * kDegrees, Eigen::Vector3d::UnitZ()) *
            ahead;
        cameras.push_back(LookAt(intrinsics, eye, eye + turned));
        break;
      }
      case TrainingMotion::kStatic:
        cameras.push_back(
            LookAt(intrinsics, eye_at(kTrainingAzimuth), scene.target));
        break;
      case TrainingMotion::kHandheldStill: {
        const Eigen::Vector3d shake(tremor(tremor_rng), tremor(tremor_rng),
                                    tremor(tremor_rng));
        cameras.push_back(LookAt(
            intrinsics,
            eye_at(kTrainingAzimuth) + kHandheldDriftShare * position_sway,
            scene.target + kHandheldDriftShare * aim_sway + shake));
        break;
      }
    }
  }
  return cameras;
}

PosedCamera ValidationCamera(const Scene& scene, const Camera& intrinsics,
                             int index) {
  return LookAt(intrinsics, ValidationEye(scene, index), scene.target);
}

}  // namespace pano4d::synth
