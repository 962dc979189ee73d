#include "src/core/rigid.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

Rigid3d RandomRigid(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Rigid3d::FromColmap({n(rng), n(rng), n(rng), n(rng)},
                             {n(rng), n(rng), n(rng)});
}

TEST(RigidTest, ColmapQvecIsWxyzWorldToCamera) {
  // 90 degrees about z: qvec = (cos 45, 0, 0, sin 45) maps x to y.
  const double s = std::sqrt(0.5);
  const Rigid3d cam_from_world = Rigid3d::FromColmap({s, 0, 0, s}, {1, 2, 3});
  EXPECT_LT(
      (cam_from_world * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1, 3, 3))
          .norm(),
      1e-15);
  EXPECT_LT((cam_from_world.ColmapQvec() - Eigen::Vector4d(s, 0, 0, s)).norm(),
            1e-15);
  // Unnormalized input is normalized.
  const Rigid3d scaled = Rigid3d::FromColmap({2 * s, 0, 0, 2 * s}, {1, 2, 3});
  EXPECT_LT((scaled.ColmapQvec() - Eigen::Vector4d(s, 0, 0, s)).norm(), 1e-15);
}

// A quaternion whose norm overflows is still a rotation, not the zero
// quaternion.
TEST(RigidTest, AHugeQvecIsNormalisedWithoutOverflow) {
  const Rigid3d r = Rigid3d::FromColmap({1e300, 0, 0, 1e300}, {0, 0, 0});
  EXPECT_NEAR(r.rotation.norm(), 1.0, 1e-12);
  EXPECT_NEAR(r.rotation.w(), std::sqrt(0.5), 1e-12);
  EXPECT_THROW(Rigid3d::FromColmap({0, 0, 0, 0}, {0, 0, 0}), Error);
  EXPECT_THROW(Rigid3d::FromColmap({1e308, 1e308, 0, HUGE_VAL}, {0, 0, 0}),
               Error);
}

TEST(RigidTest, CameraCentreMapsToTheOrigin) {
  std::mt19937 rng(1);
  for (int i = 0; i < 20; ++i) {
    const Rigid3d cam_from_world = RandomRigid(rng);
    const Eigen::Vector3d c = CameraCenter(cam_from_world);
    EXPECT_LT((cam_from_world * c).norm(), 1e-12);
    const Eigen::Matrix3d R = cam_from_world.rotation.toRotationMatrix();
    EXPECT_LT((c + R.transpose() * cam_from_world.translation).norm(), 1e-12);
  }
}

TEST(RigidTest, InverseAndComposition) {
  std::mt19937 rng(2);
  for (int i = 0; i < 20; ++i) {
    const Rigid3d a = RandomRigid(rng), b = RandomRigid(rng);
    const Eigen::Vector3d x(0.3, -1.2, 2.5);
    EXPECT_LT(((a * b) * x - a * (b * x)).norm(), 1e-12);
    EXPECT_LT((a.Inverse() * (a * x) - x).norm(), 1e-12);
    EXPECT_LT((a.ToMatrix() * x.homogeneous() - a * x).norm(), 1e-12);
  }
}

TEST(RigidTest, ZeroOrNonFiniteQuaternionIsAnError) {
  EXPECT_THROW(Rigid3d::FromColmap({0, 0, 0, 0}, {0, 0, 0}), Error);
  EXPECT_THROW(Rigid3d::FromColmap({1, 0, std::nan(""), 0}, {0, 0, 0}), Error);
  EXPECT_THROW(Rigid3d::FromColmap({1, 0, 0, 0}, {0, INFINITY, 0}), Error);
}

TEST(Sim3Test, MatrixRoundTripInverseComposition) {
  const Sim3d a(2.5,
                Eigen::Quaterniond(Eigen::AngleAxisd(
                    0.7, Eigen::Vector3d(1, 2, 3).normalized())),
                {1, -2, 0.5});
  const Sim3d b(
      0.3,
      Eigen::Quaterniond(Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY())),
      {0, 4, 1});
  const Eigen::Vector3d x(0.3, -1.2, 2.5);
  const Sim3d back = Sim3d::FromMatrix(a.ToMatrix());
  EXPECT_NEAR(back.scale, 2.5, 1e-12);
  EXPECT_LT((back * x - a * x).norm(), 1e-12);
  EXPECT_LT((a.Inverse() * (a * x) - x).norm(), 1e-12);
  EXPECT_LT(((a * b) * x - a * (b * x)).norm(), 1e-12);
}

TEST(Sim3Test, FromMatrixRejectsNonSimilarities) {
  Eigen::Matrix4d reflection = Eigen::Matrix4d::Identity();
  reflection(0, 0) = -1;
  EXPECT_THROW(Sim3d::FromMatrix(reflection), Error);
  Eigen::Matrix4d shear = Eigen::Matrix4d::Identity();
  shear(0, 1) = 0.5;
  EXPECT_THROW(Sim3d::FromMatrix(shear), Error);
}

TEST(Sim3Test, TransformedPoseSeesTheTransformedWorldTheSame) {
  std::mt19937 rng(5);
  const Sim3d b_from_a(1.7,
                       Eigen::Quaterniond(Eigen::AngleAxisd(
                           0.4, Eigen::Vector3d(0, 1, 1).normalized())),
                       {0.5, 0.1, -3});
  for (int i = 0; i < 10; ++i) {
    const Rigid3d cam_from_a = RandomRigid(rng);
    const Rigid3d cam_from_b = b_from_a.TransformPose(cam_from_a);
    EXPECT_LT(
        (CameraCenter(cam_from_b) - b_from_a * CameraCenter(cam_from_a)).norm(),
        1e-12);
    const Eigen::Vector3d x_a(1, 2, 3);
    // Same direction in the camera, distances scaled.
    EXPECT_LT(
        (cam_from_b * (b_from_a * x_a) - b_from_a.scale * (cam_from_a * x_a))
            .norm(),
        1e-11);
  }
}

}  // namespace
}  // namespace pano4d
