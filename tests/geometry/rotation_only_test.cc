#include "src/geometry/rotation_only.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "src/core/error.h"

namespace pano4d {
namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kFocal = 300;

Eigen::Matrix3d Pan(double yaw_degrees, double pitch_degrees) {
  return (Eigen::AngleAxisd(pitch_degrees * M_PI / 180,
                            Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(yaw_degrees * M_PI / 180, Eigen::Vector3d::UnitY()))
      .toRotationMatrix();
}

// Frames of a camera turning about its centre, and the matches of each
// frame with its next `neighbours`, with pixel noise and some outliers.
struct Scene {
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<FrameMatches> pairs;
};

Scene MakePan(int frames, int neighbours, double noise_pixels,
              double outlier_share) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, noise_pixels);
  std::uniform_real_distribution<double> unit(-1, 1), pixel_x(0, kWidth),
      pixel_y(0, kHeight), share(0, 1);
  Scene s;
  for (int f = 0; f < frames; ++f)
    s.rotations.push_back(
        Pan(-25 + 50.0 * f / (frames - 1), 4 * std::sin(f * 0.3)));
  std::vector<Eigen::Vector3d> directions;
  for (int k = 0; k < 4000; ++k)
    directions.push_back(
        Eigen::Vector3d(unit(rng), unit(rng), 1.5).normalized());
  const auto project =
      [&](const Eigen::Matrix3d& r,
          const Eigen::Vector3d& d) -> std::optional<Eigen::Vector2d> {
    const Eigen::Vector3d c = r * d;
    if (c.z() <= 0) return std::nullopt;
    const Eigen::Vector2d x(kFocal * c.x() / c.z() + kWidth / 2.0,
                            kFocal * c.y() / c.z() + kHeight / 2.0);
    if (x.x() < 0 || x.y() < 0 || x.x() >= kWidth || x.y() >= kHeight)
      return std::nullopt;
    return x;
  };
  for (int i = 0; i < frames; ++i) {
    for (int j = i + 1; j <= std::min(frames - 1, i + neighbours); ++j) {
      FrameMatches m{i, j, {}, {}};
      for (const Eigen::Vector3d& d : directions) {
        const auto xi = project(s.rotations[i], d);
        const auto xj = project(s.rotations[j], d);
        if (!xi || !xj) continue;
        m.xi.push_back(*xi + Eigen::Vector2d(noise(rng), noise(rng)));
        if (share(rng) < outlier_share)
          m.xj.emplace_back(pixel_x(rng), pixel_y(rng));
        else
          m.xj.push_back(*xj + Eigen::Vector2d(noise(rng), noise(rng)));
      }
      s.pairs.push_back(std::move(m));
    }
  }
  return s;
}

double Degrees(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() * 180 / M_PI;
}

TEST(RotationOnlyTest, RecoversThePanAndTheFocalLength) {
  const Scene s = MakePan(24, 3, 0.5, 0.2);
  const RotationOnlyEstimate e =
      EstimateRotationOnly(24, kWidth, kHeight, s.pairs);
  ASSERT_EQ(e.Posed(), 24);
  EXPECT_NEAR(e.focal, kFocal, 0.01 * kFocal);
  EXPECT_LT(e.rms_pixels, 1.0);
  // The world is the first frame's camera.
  EXPECT_LT(Degrees(*e.cam_from_world[0], Eigen::Matrix3d::Identity()), 1e-9);
  double worst = 0;
  for (int f = 0; f < 24; ++f) {
    const Eigen::Matrix3d truth = s.rotations[f] * s.rotations[0].transpose();
    worst = std::max(worst, Degrees(*e.cam_from_world[f], truth));
  }
  std::printf(
      "focal %.2f (truth %.0f), worst rotation error %.4f deg, rms %.3f px\n",
      e.focal, kFocal, worst, e.rms_pixels);
  // Issue 36 asks 1 degree of a pan video; half-pixel noise gives about 0.1.
  EXPECT_LT(worst, 0.25);
}

TEST(RotationOnlyTest, AFrameNoPairReachesIsLeftUnposed) {
  Scene s = MakePan(10, 2, 0.3, 0.0);
  // Frame 9 keeps only a pair with too few matches.
  for (FrameMatches& m : s.pairs) {
    if (m.j == 9) {
      m.xi.resize(5);
      m.xj.resize(5);
    }
  }
  const RotationOnlyEstimate e =
      EstimateRotationOnly(10, kWidth, kHeight, s.pairs);
  EXPECT_EQ(e.Posed(), 9);
  EXPECT_FALSE(e.cam_from_world[9].has_value());
}

TEST(RotationOnlyTest, AStillCameraGetsOnePoseAndThePriorFocalLength) {
  Scene s = MakePan(6, 2, 0.2, 0.0);
  for (FrameMatches& m : s.pairs) m.xj = m.xi;  // nothing moves
  const RotationOnlyEstimate e =
      EstimateRotationOnly(6, kWidth, kHeight, s.pairs);
  ASSERT_EQ(e.Posed(), 6);
  for (const auto& r : e.cam_from_world)
    EXPECT_LT(Degrees(*r, Eigen::Matrix3d::Identity()), 1e-12);
  EXPECT_DOUBLE_EQ(e.focal, 1.2 * kWidth);
  EXPECT_LT(e.rms_pixels, 1e-9);
}

TEST(RotationOnlyTest, NoUsablePairOrUnequalMatchesAreErrors) {
  EXPECT_THROW(EstimateRotationOnly(3, kWidth, kHeight, {}), Error);
  FrameMatches bad{0, 1, {Eigen::Vector2d(1, 2)}, {}};
  EXPECT_THROW(EstimateRotationOnly(3, kWidth, kHeight, {bad}), Error);
}

}  // namespace
}  // namespace pano4d
