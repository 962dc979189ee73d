#include "colmap_ext/alignment.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"

namespace pano4d {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

std::vector<Rigid3d> RandomTrajectory(int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<Rigid3d> poses;
  for (int i = 0; i < count; ++i)
    poses.emplace_back(RandomRotation(rng),
                       Eigen::Vector3d(u(rng), u(rng), u(rng)));
  return poses;
}

TEST(AlignmentTest, RecoversAKnownSimilarity) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5, 5);
  const Sim3d truth(2.7, RandomRotation(rng), {1.0, -4.0, 0.5});
  std::vector<Eigen::Vector3d> source, target;
  for (int i = 0; i < 20; ++i) {
    source.emplace_back(u(rng), u(rng), u(rng));
    target.push_back(truth * source.back());
  }
  const Sim3d found = AlignPoints(source, target);
  EXPECT_NEAR(found.scale, truth.scale, 1e-9);
  EXPECT_LT(found.rotation.angularDistance(truth.rotation), 1e-9);
  EXPECT_LT((found.translation - truth.translation).norm(), 1e-9);
}

TEST(AlignmentTest, AlignedCopyOfATrajectoryHasNoError) {
  std::mt19937 rng(5);
  const std::vector<Rigid3d> reference = RandomTrajectory(12, rng);
  // The estimate lives in another world frame and scale.
  const Sim3d estimate_from_reference(0.3, RandomRotation(rng), {5, 6, 7});
  std::vector<Rigid3d> estimate;
  for (const Rigid3d& pose : reference)
    estimate.push_back(estimate_from_reference.TransformPose(pose));
  const TrajectoryErrors e = CompareTrajectories(estimate, reference);
  EXPECT_EQ(e.cameras, 12);
  EXPECT_NEAR(e.reference_from_estimate.scale, 1 / 0.3, 1e-9);
  EXPECT_LT(e.ate_max, 1e-9);
  EXPECT_LT(e.rpe_translation_rmse, 1e-9);
  EXPECT_LT(e.rpe_rotation_rmse_deg, 1e-6);
}

TEST(AlignmentTest, ErrorsMeasureKnownPerturbations) {
  std::mt19937 rng(7);
  const std::vector<Rigid3d> reference = RandomTrajectory(40, rng);
  std::vector<Rigid3d> estimate = reference;
  // Rotate one camera by 2 degrees about its own centre: the centres, and
  // so ATE, do not change; the two relative poses around it are off by 2
  // degrees each.
  const Eigen::Vector3d centre = CameraCenter(estimate[10]);
  estimate[10].rotation =
      Eigen::AngleAxisd(2.0 * M_PI / 180, Eigen::Vector3d::UnitZ()) *
      estimate[10].rotation;
  estimate[10].translation = -(estimate[10].rotation * centre);
  TrajectoryErrors e = CompareTrajectories(estimate, reference);
  EXPECT_LT(e.ate_max, 1e-9);
  EXPECT_NEAR(e.rpe_rotation_rmse_deg, std::sqrt(2 * 4.0 / 39), 1e-6);

  // Move one centre by 0.5: alignment spreads some of it, the others stay
  // near 0, and the moved camera carries most of the error.
  estimate = reference;
  const Eigen::Vector3d moved =
      CameraCenter(estimate[20]) + Eigen::Vector3d(0.5, 0, 0);
  estimate[20].translation = -(estimate[20].rotation * moved);
  e = CompareTrajectories(estimate, reference);
  EXPECT_NEAR(e.ate_max, 0.5, 0.05);
  EXPECT_LT(e.ate_median, 0.05);
  EXPECT_GT(e.ate_rmse, 0.5 / std::sqrt(40.0) * 0.8);
}

TEST(AlignmentTest, DegenerateInputsAreErrors) {
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(AlignPoints(two, two), Error);
  const std::vector<Eigen::Vector3d> line = {
      {0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  EXPECT_THROW(AlignPoints(line, line), Error);
  std::vector<Eigen::Vector3d> a = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  std::vector<Eigen::Vector3d> b = a;
  b.pop_back();
  EXPECT_THROW(AlignPoints(a, b), Error);
  b = a;
  b[1].x() = std::nan("");
  EXPECT_THROW(AlignPoints(a, b), Error);
}

TEST(AlignmentTest, RobustExtentIgnoresFarOutliers) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 100; ++i) points.emplace_back(i / 100.0 * 3, 0, 0);
  EXPECT_NEAR(RobustExtent(points), 3 * 0.9, 0.05);
  points.emplace_back(1e6, 1e6, 1e6);  // one wild triangulation
  EXPECT_NEAR(RobustExtent(points), 3 * 0.9, 0.1);
  points.resize(5);
  EXPECT_EQ(RobustExtent(points), 0.0);
}

}  // namespace
}  // namespace pano4d
