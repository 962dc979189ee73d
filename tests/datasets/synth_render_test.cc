#include "src/datasets/synth_render.h"

#include <cmath>

#include <gtest/gtest.h>

#include "src/datasets/synth_cameras.h"

namespace pano4d::synth {
namespace {

const Camera kTiny{CameraModelId::kPinhole, 128, 96, {115.2, 115.2, 64, 48}};

double Bilinear(const cv::Mat& depth, double x, double y, bool* smooth) {
  // Depth samples sit at pixel centres.
  const double fx = x - 0.5, fy = y - 0.5;
  const int x0 = static_cast<int>(std::floor(fx)),
            y0 = static_cast<int>(std::floor(fy));
  *smooth = false;
  if (x0 < 0 || y0 < 0 || x0 + 1 >= depth.cols || y0 + 1 >= depth.rows)
    return 0;
  const double a = depth.at<float>(y0, x0), b = depth.at<float>(y0, x0 + 1),
               c = depth.at<float>(y0 + 1, x0),
               d = depth.at<float>(y0 + 1, x0 + 1);
  const double lo = std::min({a, b, c, d}), hi = std::max({a, b, c, d});
  *smooth = lo > 0 && hi < 1.02 * lo;
  const double u = fx - x0, v = fy - y0;
  return (1 - v) * ((1 - u) * a + u * b) + v * ((1 - u) * c + u * d);
}

Eigen::Vector3d Backproject(const PosedCamera& camera,
                            const Eigen::Vector2d& pixel, double depth) {
  const UnprojectResult r = camera.camera.Unproject(pixel);
  const Eigen::Vector3d cam(r.normalized.x() * depth, r.normalized.y() * depth,
                            depth);
  return camera.cam_from_world.Inverse() * cam;
}

TEST(SynthRenderTest, DepthIsZOfTheSurfaceThroughThePixelCentre) {
  // Back-projecting a pixel centre with its depth lands on the surface point
  // the ray tracer hit, for every pixel: a renderer shooting through pixel
  // corners, or storing distance along the ray instead of z, would miss by
  // centimetres.
  const Scene scene = BuildScene(0, false);
  const double s = 3 / 7.0;
  const PosedCamera camera = TrainingTrajectory(scene, kTiny, 8, 0)[3];
  const RenderedFrame frame = RenderFrame(scene, camera, s, false, true);
  const PartPoses poses = PosesAt(scene, s);
  int pixels = 0;
  for (int y = 0; y < kTiny.height; ++y) {
    for (int x = 0; x < kTiny.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * kTiny.width + x;
      ASSERT_GE(frame.part[i], 0);  // a closed room: every ray hits
      const double depth = frame.depth.at<float>(y, x);
      const Eigen::Vector3d hit =
          poses.world_from_part[frame.part[i]] * frame.local[i];
      const Eigen::Vector3d back =
          Backproject(camera, {x + 0.5, y + 0.5}, depth);
      EXPECT_LT((back - hit).norm(), 1e-6 * depth)
          << x << "," << y;  // float32 depth
      ++pixels;
    }
  }
  EXPECT_EQ(pixels, kTiny.width * kTiny.height);
}

TEST(SynthRenderTest, StaticDepthReprojectsBetweenFramesWithinHalfAPixel) {
  const Scene scene = BuildScene(0, false);
  const std::vector<PosedCamera> cameras =
      TrainingTrajectory(scene, kTiny, 8, 0);
  const int a = 0, b = 5;
  const RenderedFrame fa =
      RenderFrame(scene, cameras[a], a / 7.0, false, false);
  const RenderedFrame fb =
      RenderFrame(scene, cameras[b], b / 7.0, false, false);
  int checked = 0, within = 0;
  std::vector<double> errors;
  for (int y = 0; y < kTiny.height; ++y) {
    for (int x = 0; x < kTiny.width; ++x) {
      if (fa.dynamic.at<std::uint8_t>(y, x) != 0 ||
          fa.depth.at<float>(y, x) <= 0)
        continue;
      const Eigen::Vector2d p(x + 0.5, y + 0.5);
      const Eigen::Vector3d world =
          Backproject(cameras[a], p, fa.depth.at<float>(y, x));
      const std::optional<Eigen::Vector2d> q = cameras[b].Project(world);
      if (!q) continue;
      bool smooth = false;
      const double depth_b = Bilinear(fb.depth, q->x(), q->y(), &smooth);
      const double z_b = (cameras[b].cam_from_world * world).z();
      if (!smooth || std::abs(z_b - depth_b) > 0.02 * depth_b)
        continue;  // occluded or at an edge
      if (fb.dynamic.at<std::uint8_t>(static_cast<int>(q->y()),
                                      static_cast<int>(q->x())) != 0)
        continue;
      const Eigen::Vector3d back = Backproject(cameras[b], *q, depth_b);
      const std::optional<Eigen::Vector2d> p2 = cameras[a].Project(back);
      ASSERT_TRUE(p2.has_value());
      const double error = (*p2 - p).norm();
      errors.push_back(error);
      ++checked;
      within += error < 0.5;
    }
  }
  ASSERT_GT(checked, 3000);
  std::sort(errors.begin(), errors.end());
  EXPECT_GE(within, 0.99 * checked) << "of " << checked;
  EXPECT_LT(errors[errors.size() / 2], 0.05);
}

TEST(SynthRenderTest, CovisibilityOfAConstructedCase) {
  // Room with a box; training cameras on the -y side looking at +y.
  Scene scene;
  Part room;
  room.shape = ShapeKind::kRoom;
  room.half_size = {4, 3, 1.5};
  room.rest = Rigid3d(Eigen::Quaterniond::Identity(), {0, 0, 1.5});
  Part box;
  box.half_size = {0.5, 0.5, 0.5};
  box.rest = Rigid3d(Eigen::Quaterniond::Identity(), {0, 0, 0.5});
  scene.parts = {room, box};
  std::vector<TrainingView> train;
  for (int t = 0; t < 10; ++t) {
    const PosedCamera camera =
        LookAt(kTiny, {-0.5 + 0.1 * t, -2.5, 1.2}, {0.0, 3.0, 1.2});
    TrainingView view{camera, PosesAt(scene, 0), {}};
    view.depth = RenderFrame(scene, camera, 0, false, false).depth;
    train.push_back(view);
  }
  // Two surface points: the middle of the far wall, which every training
  // camera faces, and the middle of the box's far (+y) face.
  RenderedFrame val;
  val.depth = cv::Mat(1, 2, CV_32FC1, cv::Scalar(1));
  val.part = {0, 1};
  val.local = {Eigen::Vector3d(0, 3, 0), Eigen::Vector3d(0, 0.5, 0)};
  const cv::Mat counts = CovisibleCounts(val, train);
  EXPECT_EQ(counts.at<int>(0, 0), 10);
  EXPECT_EQ(counts.at<int>(0, 1), 0);
  const cv::Mat mask = CovisibleMask(counts, 10);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 0), 255);
  EXPECT_EQ(mask.at<std::uint8_t>(0, 1), 0);
}

TEST(SynthRenderTest, ThresholdFollowsDyCheck) {
  EXPECT_EQ(CovisibilityThreshold(8), 5);
  EXPECT_EQ(CovisibilityThreshold(48), 5);
  EXPECT_EQ(CovisibilityThreshold(120), 12);
  const cv::Mat counts = (cv::Mat_<int>(1, 3) << 5, 6, 12);
  const cv::Mat mask = CovisibleMask(counts, 120);  // more than 12
  EXPECT_EQ(cv::countNonZero(mask), 0);
  EXPECT_EQ(cv::countNonZero(CovisibleMask(counts, 48)), 2);  // more than 5
}

}  // namespace
}  // namespace pano4d::synth
