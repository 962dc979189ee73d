#include "src/pano/trajectory.h"

#include <cmath>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/pano/look_at.h"

namespace pano4d {
namespace {

constexpr double kDeg = M_PI / 180.0;

using testing::LookAt;

double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

Eigen::Vector2d PixelOf(const RasterCamera& c, const Eigen::Vector3d& world) {
  const Eigen::Vector3d p =
      c.rotation.cast<double>() * world + c.translation.cast<double>();
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

TEST(TrajectoryTest, DirectionsAreEvenlySpacedInTheTangentPlane) {
  const RasterCamera ref = LookAt({1, -4, 2}, {0, 1, 0.5f});
  const Eigen::Vector3d n = ViewingDirection(ref);
  for (int m = 0; m < 8; ++m) {
    const Eigen::Vector3d d = TangentDirection(ref, m, 8);
    EXPECT_NEAR(d.norm(), 1.0, 1e-6);
    EXPECT_NEAR(d.dot(n), 0.0, 1e-6);
    EXPECT_NEAR(Angle(d, TangentDirection(ref, (m + 1) % 8, 8)), M_PI / 4,
                1e-6);
    const Eigen::Vector3d a = RotationAxis(n, d);
    EXPECT_NEAR(a.norm(), 1.0, 1e-9);
    EXPECT_NEAR(a.dot(n), 0.0, 1e-6);
    EXPECT_NEAR(a.dot(d), 0.0, 1e-6);
  }
  // m = 0 is the camera's right, m = M/4 its up (-y).
  EXPECT_LT((TangentDirection(ref, 0, 8) -
             ref.rotation.row(0).transpose().cast<double>())
                .norm(),
            1e-6);
  EXPECT_LT((TangentDirection(ref, 2, 8) +
             ref.rotation.row(1).transpose().cast<double>())
                .norm(),
            1e-6);
}

TEST(TrajectoryTest, StepETurnsTheViewByEAlphaTowardsDm) {
  const RasterCamera ref = LookAt({1, -4, 2}, {0, 1, 0.5f});
  const Eigen::Vector3d center(0, 1, 0.5);
  const Eigen::Vector3d n = ViewingDirection(ref);
  for (int m = 0; m < 8; ++m) {
    const Eigen::Vector3d d = TangentDirection(ref, m, 8);
    const Eigen::Vector3d a = RotationAxis(n, d);
    for (int e = 0; e <= 6; ++e) {
      const double angle = e * 15 * kDeg;
      const Eigen::Vector3d s = ExpandedDirection(n, a, angle);
      EXPECT_NEAR(s.norm(), 1.0, 1e-9);
      EXPECT_NEAR(Angle(s, n), angle, 1e-9) << "m " << m << " e " << e;
      if (e > 0) {
        EXPECT_GT(s.dot(d), 0);  // turns towards d_m
      }
      // The orbited camera looks along s, keeps its distance to the centre,
      // and sees the centre at the same pixel.
      const RasterCamera c = OrbitCamera(ref, center, a, angle);
      EXPECT_LT((ViewingDirection(c) - s).norm(), 1e-5);
      EXPECT_NEAR((c.Center().cast<double>() - center).norm(),
                  (ref.Center().cast<double>() - center).norm(), 1e-5);
      EXPECT_LT((PixelOf(c, center) - PixelOf(ref, center)).norm(), 1e-3);
      EXPECT_NEAR(
          (c.rotation * c.rotation.transpose() - Eigen::Matrix3f::Identity())
              .norm(),
          0.0, 1e-5);
    }
  }
}

TEST(TrajectoryTest, StepZeroIsTheSourceCamera) {
  const RasterCamera ref = LookAt({1, -4, 2}, {0, 1, 0.5f});
  const std::vector<RasterCamera> sources = {ref,
                                             LookAt({2, -4, 2}, {0, 1, 0})};
  for (bool planar : {false, true}) {
    ExpansionGeometry g;
    g.planar = planar;
    g.steps = 5;  // planar: below 90 degrees in all
    const auto views =
        ExpansionViews(g, ref, Eigen::Vector3d(0, 1, 0.5), sources, {0, 7}, 0);
    ASSERT_EQ(views.size(), 16u);
    for (const ExpandedView& v : views) {
      const RasterCamera& s = sources[v.t == 0 ? 0 : 1];
      EXPECT_LT((v.camera.rotation - s.rotation).norm(), 1e-6);
      EXPECT_LT((v.camera.translation - s.translation).norm(), 1e-5);
    }
  }
}

TEST(TrajectoryTest, PlanarCameraShiftsTheCentreByTheSameAngle) {
  const Eigen::Vector3d center(0, 1, 0.5);
  const RasterCamera ref = LookAt({1, -4, 2}, center.cast<float>());
  const Eigen::Vector3d n = ViewingDirection(ref);
  const Eigen::Vector3d d = TangentDirection(ref, 3, 8);
  const RasterCamera c = PlanarCamera(ref, center, d, 30 * kDeg);
  EXPECT_LT((c.rotation - ref.rotation).norm(), 1e-6);
  const Eigen::Vector3d to_center = center - c.Center().cast<double>();
  EXPECT_NEAR(Angle(to_center, n), 30 * kDeg, 1e-5);
  EXPECT_THROW(PlanarCamera(ref, center, d, 89.5 * kDeg), Error);
}

TEST(TrajectoryTest, OptionsAreChecked) {
  ExpansionGeometry g;
  EXPECT_NO_THROW(g.Check());
  g.directions = 0;
  EXPECT_THROW(g.Check(), Error);
  g = ExpansionGeometry();
  g.alpha_degrees = 40;  // 6 x 40 > 180
  EXPECT_THROW(g.Check(), Error);
  g = ExpansionGeometry();
  g.planar = true;
  g.alpha_degrees = 15;  // 90 degrees in all: tan is unbounded
  EXPECT_THROW(g.Check(), Error);
  g.steps = 5;
  EXPECT_NO_THROW(g.Check());
}

TEST(TrajectoryTest, JsonHoldsColmapPose) {
  ExpandedView v;
  v.m = 2;
  v.e = 3;
  v.t = 11;
  v.camera = LookAt({1, -4, 2}, {0, 1, 0.5f});
  const nlohmann::json j = ToJson(v);
  EXPECT_EQ(j["m"], 2);
  EXPECT_EQ(j["e"], 3);
  EXPECT_EQ(j["t"], 11);
  const auto& q = j["camera"]["qvec"];
  const Eigen::Quaterniond quat(q[0].get<double>(), q[1].get<double>(),
                                q[2].get<double>(), q[3].get<double>());
  EXPECT_LT((quat.toRotationMatrix().cast<float>() - v.camera.rotation).norm(),
            1e-5);
  EXPECT_NEAR(j["camera"]["tvec"][2].get<double>(), v.camera.translation.z(),
              1e-6);
  EXPECT_EQ(j["camera"]["width"], 64);
}

TEST(TrajectoryTest, CameraJsonRoundTripsAndBadCamerasAreNamed) {
  const RasterCamera c = LookAt({1, -4, 2}, {0, 1, 0.5f});
  const RasterCamera back = RasterCameraFromJson(CameraToJson(c), "cam");
  EXPECT_EQ(back.width, c.width);
  EXPECT_FLOAT_EQ(back.fx, c.fx);
  EXPECT_LT((back.rotation - c.rotation).norm(), 1e-5);
  EXPECT_LT((back.translation - c.translation).norm(), 1e-5);
  nlohmann::json bad = CameraToJson(c);
  bad["qvec"] = {0, 0, 0, 0};
  EXPECT_THROW(RasterCameraFromJson(bad, "cam"), Error);
  bad = CameraToJson(c);
  bad.erase("fx");
  try {
    RasterCameraFromJson(bad, "views.json view 3");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("views.json view 3"),
              std::string::npos);
    EXPECT_NE(std::string(e.what()).find("fx"), std::string::npos);
  }
}

TEST(TrajectoryTest, VideoPathsKeepTheCentreInViewAndTheirTimes) {
  const Eigen::Vector3d center(0, 1, 0.5);
  const RasterCamera ref = LookAt({1, -4, 2}, center.cast<float>());
  const Eigen::Vector2d at = PixelOf(ref, center);
  const double distance = (ref.Center().cast<double>() - center).norm();
  VideoPathOptions o;
  o.frames = 24;
  o.num_times = 12;
  for (VideoPath path :
       {VideoPath::kOrbit, VideoPath::kSpiral, VideoPath::kBullet}) {
    o.path = path;
    o.degrees = path == VideoPath::kSpiral ? 10 : 360;
    o.time = 5;
    const std::vector<TimedCamera> cams = VideoCameras(o, ref, center);
    ASSERT_EQ(cams.size(), 24u);
    for (std::size_t k = 0; k < cams.size(); ++k) {
      const RasterCamera& c = cams[k].camera;
      // A rigid motion about the centre: same distance, same pixel.
      EXPECT_NEAR((c.Center().cast<double>() - center).norm(), distance, 1e-4);
      EXPECT_LT((PixelOf(c, center) - at).norm(), 1e-2);
      if (path == VideoPath::kBullet) {
        EXPECT_EQ(cams[k].time, 5);
      } else {
        EXPECT_EQ(cams[k].time, static_cast<int>(k) / 2);  // 24 over 12
      }
    }
  }
  // The orbit starts at the reference and turns about its up axis: half way
  // round, the camera is behind the centre.
  o.path = VideoPath::kOrbit;
  o.degrees = 360;
  const std::vector<TimedCamera> orbit = VideoCameras(o, ref, center);
  EXPECT_LT((orbit[0].camera.Center() - ref.Center()).norm(), 1e-5);
  const Eigen::Vector3d behind = 2 * center - ref.Center().cast<double>();
  const Eigen::Vector3d up = -ref.rotation.cast<double>().row(1).transpose();
  const Eigen::Vector3d half = orbit[12].camera.Center().cast<double>();
  // Reflected through the up axis: equal height along up, opposite side.
  EXPECT_NEAR((half - center).dot(up),
              (ref.Center().cast<double>() - center).dot(up), 1e-4);
  EXPECT_LT(((half - behind) - (half - behind).dot(up) * up).norm(), 1e-3);
  // The bullet swings +-degrees/2: frame 0 and the middle are `degrees` apart.
  o.path = VideoPath::kBullet;
  o.degrees = 60;
  const std::vector<TimedCamera> bullet = VideoCameras(o, ref, center);
  const Eigen::Vector3d a = bullet[0].camera.Center().cast<double>() - center;
  const Eigen::Vector3d b = bullet[12].camera.Center().cast<double>() - center;
  const auto flat = [&](const Eigen::Vector3d& v) {
    return v - v.dot(up) * up;
  };
  EXPECT_NEAR(Angle(flat(a), flat(b)), 60 * kDeg, 1e-4);

  o.degrees = 0;
  EXPECT_THROW(VideoCameras(o, ref, center), Error);
  o.degrees = 30;
  o.time = 12;
  EXPECT_THROW(VideoCameras(o, ref, center), Error);
}

}  // namespace
}  // namespace pano4d
