#include "src/pano/layout.h"

#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

namespace pano4d {
namespace {

const Eigen::Vector3f kFloor(0.6f, 0.6f, 0.2f), kBackWall(0.2f, 0.5f, 0.2f),
    kSideWall(0.8f, 0.3f, 0.3f), kClutter(0.1f, 0.1f, 0.9f);

// A room x in [-4, 4], y in [-3, 3], z in [0, 3] of which a camera saw part
// of the floor, the back wall (y = 3) and one side wall (x = 4), with a box
// on the floor: its points turned by `world_from_room`, the way a
// reconstruction's axes lie anywhere.
PointCloud SeenRoom(const Eigen::Matrix3f& world_from_room) {
  std::mt19937 rng(11);
  const auto u = [&](float lo, float hi) {
    return std::uniform_real_distribution<float>(lo, hi)(rng);
  };
  std::normal_distribution<float> noise(0, 0.01f);
  PointCloud cloud;
  const auto add = [&](const Eigen::Vector3f& room, const Eigen::Vector3f& c) {
    cloud.points.push_back(world_from_room * room);
    cloud.colors.push_back(c);
  };
  for (int i = 0; i < 2000; ++i)
    add({u(-3.5f, 4), u(-2, 3), noise(rng)}, kFloor);
  for (int i = 0; i < 1500; ++i)
    add({u(-3.5f, 4), 3 + noise(rng), u(0, 3)}, kBackWall);
  for (int i = 0; i < 800; ++i)
    add({4 + noise(rng), u(-2, 3), u(0, 3)}, kSideWall);
  for (int i = 0; i < 400; ++i) {  // a 0.6 m box's top and two sides
    const int side = i % 3;
    Eigen::Vector3f p(u(-0.3f, 0.3f), u(0.7f, 1.3f), u(0, 0.6f));
    if (side == 0) p.z() = 0.6f;
    if (side == 1) p.x() = -0.3f;
    if (side == 2) p.y() = 0.7f;
    add(p, kClutter);
  }
  return cloud;
}

Eigen::Matrix3f Turn() {
  return Eigen::AngleAxisf(0.7f, Eigen::Vector3f(1, 2, 3).normalized())
      .toRotationMatrix();
}

TEST(LayoutTest, ARoomsBoxIsItsWallsAndFloorWithTheirColours) {
  const Eigen::Matrix3f r = Turn();
  const Layout layout = FitLayout(SeenRoom(r));
  ASSERT_TRUE(layout.valid);
  // Every room axis is one of the box's axes.
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3f room_axis = r.col(j);
    const float best =
        (layout.axes.transpose() * room_axis).cwiseAbs().maxCoeff();
    EXPECT_GT(best, 0.995f) << "room axis " << j;
  }
  // From the middle of the room at 1.5 m height: down meets the floor,
  // ahead the back wall, right the side wall, each on a plane with its
  // colour.
  const Eigen::Vector3f eye = r * Eigen::Vector3f(0, 0, 1.5f);
  struct Case {
    Eigen::Vector3f direction;
    float t;
    Eigen::Vector3f colour;
  };
  for (const Case& c :
       {Case{{0, 0, -1}, 1.5f, kFloor}, Case{{0, 1, 0}, 3.0f, kBackWall},
        Case{{1, 0, 0}, 4.0f, kSideWall}}) {
    SCOPED_TRACE(c.t);
    const auto hit = layout.Exit(eye, r * c.direction);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->t, c.t, 0.03f);
    EXPECT_TRUE(layout.on_plane[hit->face]);
    EXPECT_LT((layout.colours[hit->face] - c.colour).norm(), 0.05f);
  }
  // Left and up no frame saw a wall: the box ends where the points do,
  // in the scene's mean colour.
  for (const Eigen::Vector3f& d :
       {Eigen::Vector3f(-1, 0, 0), Eigen::Vector3f(0, 0, 1)}) {
    const auto hit = layout.Exit(eye, r * d);
    ASSERT_TRUE(hit.has_value());
    EXPECT_FALSE(layout.on_plane[hit->face]);
    EXPECT_EQ(layout.colours[hit->face], layout.mean_colour);
  }
  EXPECT_NEAR(layout.Exit(eye, r * Eigen::Vector3f(-1, 0, 0))->t, 3.45f, 0.1f);
  // A ray from outside, pointing away, misses.
  EXPECT_FALSE(
      layout.Exit(r * Eigen::Vector3f(0, 0, 10), r * Eigen::Vector3f(0, 0, 1))
          .has_value());
}

TEST(LayoutTest, TheBoxHoldsTheCamerasOnFacesThatAreNoPlane) {
  // A camera at y = -2.5, outside the points' extent (the floor's points
  // start at y = -2): the wall behind it (no plane) moves out past it by
  // the margin; the floor (a plane) stays where it is.
  const Eigen::Matrix3f r = Turn();
  const Eigen::Vector3f eye = r * Eigen::Vector3f(0, -2.5f, 1.5f);
  const Layout plain = FitLayout(SeenRoom(r));
  Layout held = FitLayout(SeenRoom(r), {eye});
  HoldViewpoints({eye}, 0.5f, &held);
  ASSERT_TRUE(plain.valid && held.valid);
  const Eigen::Vector3f back = r * Eigen::Vector3f(0, -1, 0);
  const Eigen::Vector3f down = r * Eigen::Vector3f(0, 0, -1);
  const Eigen::Vector3f middle = r * Eigen::Vector3f(0, 0, 1.5f);
  EXPECT_NEAR(plain.Exit(middle, back)->t, 1.97f, 0.05f);
  EXPECT_NEAR(held.Exit(middle, back)->t, 3.0f, 1e-3f);
  EXPECT_FALSE(held.on_plane[held.Exit(middle, back)->face]);
  int up = 0;  // the box axis along the room's z
  for (int j = 1; j < 3; ++j)
    if (std::abs(held.axes.col(j).dot(r.col(2))) >
        std::abs(held.axes.col(up).dot(r.col(2))))
      up = j;
  EXPECT_EQ(held.lo[up], plain.lo[up]);
  EXPECT_EQ(held.hi[up], plain.hi[up]);  // the eye is below the top
  EXPECT_NEAR(held.Exit(eye, down)->t, 1.5f, 0.03f);
}

// One wall seen head-on (a cloud thinner than a tenth of anything): the
// wall is the box's face on the far side from the cameras, which the box
// holds in front of it.
TEST(LayoutTest, ASingleWallIsTheFaceBeyondTheCameras) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-2, 2);
  std::normal_distribution<float> noise(0, 0.01f);
  PointCloud wall;
  for (int i = 0; i < 1000; ++i) {
    wall.points.emplace_back(u(rng), 0.75f * u(rng), 3 + noise(rng));
    wall.colors.push_back(kBackWall);
  }
  for (const float eye_z : {0.0f, 6.0f}) {  // in front of it, then behind
    const Eigen::Vector3f eye(0.1f, 0, eye_z);
    Layout layout = FitLayout(wall, {eye});
    HoldViewpoints({eye}, 0.5f, &layout);
    ASSERT_TRUE(layout.valid);
    const auto hit = layout.Exit(eye, (Eigen::Vector3f(0, 0, 3) - eye));
    ASSERT_TRUE(hit);
    EXPECT_TRUE(layout.on_plane[hit->face]) << "eye at z " << eye_z;
    EXPECT_NEAR(hit->t, 1.0f, 0.02f) << "eye at z " << eye_z;
    EXPECT_EQ(layout.colours[hit->face], kBackWall);
  }
}

// The floor and the walls the frames saw are plane faces; a point is on
// one within the tolerance and inside the box along the face's two other
// axes, never on a face that is no plane or in the room's air.
TEST(LayoutTest, APointOnTheFloorOrASeenWallIsOnAPlaneFace) {
  const Eigen::Matrix3f r = Turn();
  const Layout layout = FitLayout(SeenRoom(r));
  ASSERT_TRUE(layout.valid);
  const auto face_at = [&](const Eigen::Vector3f& room, float tolerance) {
    return layout.PlaneFaceAt(r * room, tolerance);
  };
  const auto floor = face_at({0, 0, 0.02f}, 0.05f);
  ASSERT_TRUE(floor.has_value());
  EXPECT_TRUE(layout.on_plane[*floor]);
  EXPECT_LT((layout.colours[*floor] - kFloor).norm(), 0.05f);
  const auto back = face_at({1, 3.03f, 1.5f}, 0.05f);
  ASSERT_TRUE(back.has_value());
  EXPECT_NE(*back, *floor);
  EXPECT_EQ(face_at({0, 0, 0.02f}, 0.01f), std::nullopt);  // beyond tolerance
  EXPECT_EQ(face_at({0, 0, 1.5f}, 0.05f), std::nullopt);   // mid-room
  EXPECT_EQ(face_at({0, 0, 0}, 0.05f).value_or(-1), *floor);
  EXPECT_EQ(face_at({0, 9, 0}, 0.05f), std::nullopt);  // the plane, outside
  // The left wall (x = -3.45, where the points end) and the ceiling are
  // no planes.
  EXPECT_EQ(face_at({-3.45f, 0, 1.5f}, 0.1f), std::nullopt);
  EXPECT_EQ(face_at({0, 0, 2.97f}, 0.1f), std::nullopt);
  EXPECT_EQ(Layout().PlaneFaceAt(Eigen::Vector3f::Zero(), 1.0f), std::nullopt);
}

// The left wall (x = -4) of SeenRoom, which frames saw only in a strip at
// their edges: too few points for a plane of the layout's cloud, but
// enough, gathered at every pixel, to move the face that is no plane out
// to the wall, in the wall's colour. Stray points or too few leave it.
TEST(LayoutTest, AWallSeenInSliversMovesItsFaceOutToIt) {
  const Eigen::Matrix3f r = Turn();
  const Layout fitted = FitLayout(SeenRoom(r));
  ASSERT_TRUE(fitted.valid);
  const Eigen::Vector3f eye = r * Eigen::Vector3f(0, 0, 1.5f);
  const Eigen::Vector3f left = r * Eigen::Vector3f(-1, 0, 0);
  const int face = fitted.Exit(eye, left)->face;
  ASSERT_FALSE(fitted.on_plane[face]);
  EXPECT_NEAR(fitted.Exit(eye, left)->t, 3.45f, 0.1f);

  std::mt19937 rng(3);
  const auto u = [&](float lo, float hi) {
    return std::uniform_real_distribution<float>(lo, hi)(rng);
  };
  std::normal_distribution<float> noise(0, 0.01f);
  const Eigen::Vector3f kSliver(0.3f, 0.2f, 0.15f);
  const auto add = [&](PointCloud* cloud, const Eigen::Vector3f& room,
                       const Eigen::Vector3f& colour) {
    cloud->points.push_back(r * room);
    cloud->colors.push_back(colour);
  };
  PointCloud beyond;
  for (int i = 0; i < 60; ++i)  // a strip 0.2 m wide, 1.5 m high
    add(&beyond, {-4 + noise(rng), u(-1, -0.8f), u(0.5f, 2)}, kSliver);
  for (int i = 0; i < 200; ++i)  // the floor running on past the box
    add(&beyond, {u(-4, -3.6f), u(-2, 3), noise(rng)}, kFloor);
  for (int i = 0; i < 20; ++i)  // stray depth, off the wall's band
    add(&beyond, {u(-3.75f, -3.55f), u(-2, 3), u(0.5f, 2.5f)}, kClutter);
  EXPECT_TRUE(fitted.Beyond(beyond.points[0]));
  EXPECT_FALSE(fitted.Beyond(beyond.points[60]));  // on the floor's plane
  EXPECT_FALSE(fitted.Beyond(eye));

  Layout moved = fitted;
  FitSliverWalls(beyond, &moved);
  EXPECT_TRUE(moved.on_plane[face]);
  EXPECT_NEAR(moved.Exit(eye, left)->t, 4.0f, 0.02f);
  EXPECT_LT((moved.colours[face] - kSliver).norm(), 1e-3f);
  // Every other face as it was.
  for (int f = 0; f < 6; ++f) {
    if (f == face) continue;
    EXPECT_EQ(moved.on_plane[f], fitted.on_plane[f]) << "face " << f;
    EXPECT_EQ(moved.colours[f], fitted.colours[f]) << "face " << f;
  }

  // Too few wall points, or stray depth spread along the axis: nothing
  // moves.
  for (const bool wall : {true, false}) {
    PointCloud few;
    for (int i = 0; i < 20 && wall; ++i)
      add(&few, {-4 + noise(rng), u(-1, -0.8f), u(0.5f, 2)}, kSliver);
    for (int i = 0; i < 40 && !wall; ++i)
      add(&few, {u(-4, -3.55f), u(-2, 3), u(0.5f, 2.5f)}, kClutter);
    Layout same = fitted;
    FitSliverWalls(few, &same);
    EXPECT_FALSE(same.on_plane[face]) << (wall ? "20 wall points" : "stray");
    EXPECT_NEAR(same.Exit(eye, left)->t, fitted.Exit(eye, left)->t, 1e-6f);
  }

  // The top of a box standing a little taller than the points' 99th
  // percentile, two bands past the face that is no plane: the cloud's own
  // tail, no ceiling.
  const Eigen::Vector3f up = r * Eigen::Vector3f(0, 0, 1);
  const int top = fitted.Exit(eye, up)->face;
  ASSERT_FALSE(fitted.on_plane[top]);
  const float top_z = 1.5f + fitted.Exit(eye, up)->t;
  PointCloud tall;
  for (int i = 0; i < 60; ++i)
    add(&tall, {u(-0.3f, 0.3f), u(0.7f, 1.3f), top_z + 2 * fitted.band},
        kClutter);
  ASSERT_TRUE(fitted.Beyond(tall.points[0]));
  Layout same = fitted;
  FitSliverWalls(tall, &same);
  EXPECT_FALSE(same.on_plane[top]);
  EXPECT_NEAR(same.Exit(eye, up)->t, fitted.Exit(eye, up)->t, 1e-6f);
}

TEST(LayoutTest, RenderedDepthIsTheZDepthOfTheSurface) {
  const Eigen::Matrix3f r = Turn();
  const Layout layout = FitLayout(SeenRoom(r));
  ASSERT_TRUE(layout.valid);
  // A camera 1.5 m above the floor looking straight down.
  RasterCamera camera;
  camera.width = 40;
  camera.height = 30;
  camera.fx = camera.fy = 30;
  camera.cx = 20;
  camera.cy = 15;
  Eigen::Matrix3f cam_from_room;
  cam_from_room << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  camera.rotation = cam_from_room * r.transpose();
  camera.translation = -camera.rotation * (r * Eigen::Vector3f(0, 0, 1.5f));
  cv::Mat depth, rgb;
  RenderLayout(layout, camera, &depth, &rgb);
  ASSERT_EQ(depth.type(), CV_32FC1);
  ASSERT_EQ(rgb.type(), CV_32FC3);
  // The floor is flat: every pixel's z-depth is the height, not the ray's
  // length.
  for (const cv::Point p :
       {cv::Point(20, 15), cv::Point(2, 2), cv::Point(37, 27)}) {
    EXPECT_NEAR(depth.at<float>(p), 1.5f, 0.03f) << p;
    const cv::Vec3f c = rgb.at<cv::Vec3f>(p);
    EXPECT_NEAR(c[2], kFloor.z(), 0.05f) << p;
  }
}

TEST(LayoutTest, TheShellCoversEveryFaceInItsColour) {
  const Eigen::Matrix3f r = Turn();
  const Layout layout = FitLayout(SeenRoom(r));
  ASSERT_TRUE(layout.valid);
  const float spacing = 0.25f;
  const PointCloud shell = SampleLayoutFaces(layout, spacing);
  const Eigen::Vector3f size = layout.hi - layout.lo;
  const auto cells = [&](int j) { return std::ceil(size[j] / spacing); };
  EXPECT_EQ(shell.size(), static_cast<std::size_t>(2 * (cells(0) * cells(1) +
                                                        cells(1) * cells(2) +
                                                        cells(0) * cells(2))));
  ASSERT_EQ(shell.colors.size(), shell.size());
  // Each point lies on a face of the box and has that face's colour: seen
  // from the box's centre, the ray through it leaves the box there.
  const Eigen::Vector3f centre = layout.axes * ((layout.lo + layout.hi) / 2);
  for (std::size_t i = 0; i < shell.size(); i += 7) {
    const auto hit = layout.Exit(centre, shell.points[i] - centre);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->t, 1.0f, 1e-4f);
    EXPECT_EQ(shell.colors[i], layout.colours[hit->face]);
  }
  EXPECT_EQ(SampleLayoutFaces(Layout(), spacing).size(), 0u);
}

TEST(LayoutTest, TooFewPointsGiveNoLayoutAndNoDepth) {
  PointCloud few;
  for (int i = 0; i < 50; ++i) {
    few.points.emplace_back(i * 0.1f, 0, 0);
    few.colors.emplace_back(0.3f, 0.3f, 0.3f);
  }
  const Layout layout = FitLayout(few);
  EXPECT_FALSE(layout.valid);
  EXPECT_FALSE(layout.Exit({0, 0, 0}, {1, 0, 0}).has_value());
  RasterCamera camera;
  camera.width = 8;
  camera.height = 6;
  cv::Mat depth, rgb;
  RenderLayout(layout, camera, &depth, &rgb);
  EXPECT_EQ(cv::countNonZero(depth), 0);
}

}  // namespace
}  // namespace pano4d
