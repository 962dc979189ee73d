#include "src/pano/free_space.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/pano/layout.h"
#include "src/render/bench_scene.h"

namespace pano4d {
namespace {

constexpr int kWidth = 40, kHeight = 30;

RasterCamera Camera() {  // at the origin, looking down +z
  return BenchCamera(kWidth, kHeight);
}

// The world point that lands at the centre of pixel (x, y) at depth z.
Eigen::Vector3f At(int x, int y, float z) {
  const RasterCamera c = Camera();
  return Eigen::Vector3f((x + 0.5f - c.cx) / c.fx * z,
                         (y + 0.5f - c.cy) / c.fy * z, z);
}

bool SeenThrough(const std::vector<SeenDepth>& views,
                 const Eigen::Vector3f& point) {
  return Look(views, point) == Sight::kSeenThrough;
}

TEST(FreeSpaceTest, PointsInFrontOfTheSeenSurfaceAreSeenThrough) {
  const std::vector<SeenDepth> seen = {
      MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, 4.0f))};
  EXPECT_TRUE(SeenThrough(seen, At(20, 15, 3.0f)));   // 25% in front
  EXPECT_TRUE(SeenThrough(seen, At(0, 0, 3.7f)));     // 7.5%, at a corner
  EXPECT_FALSE(SeenThrough(seen, At(20, 15, 3.9f)));  // within tolerance
  EXPECT_FALSE(SeenThrough(seen, At(20, 15, 4.0f)));  // on the surface
  EXPECT_FALSE(SeenThrough(seen, At(20, 15, 6.0f)));  // hidden behind it
  EXPECT_FALSE(SeenThrough(seen, At(-3, 15, 2.0f)));  // outside the image
  EXPECT_FALSE(SeenThrough(seen, Eigen::Vector3f(0, 0, -2)));  // behind
  EXPECT_FALSE(SeenThrough({}, At(20, 15, 1.0f)));             // no views
}

TEST(FreeSpaceTest, NothingIsClaimedAtOrNextToUnknownDepth) {
  cv::Mat depth(kHeight, kWidth, CV_32FC1, 4.0f);
  depth.at<float>(10, 10) = 0;  // unknown
  depth.at<float>(10, 30) = std::numeric_limits<float>::quiet_NaN();
  depth.at<float>(20, 30) = std::numeric_limits<float>::infinity();
  const std::vector<SeenDepth> seen = {MakeSeenDepth(Camera(), depth)};
  for (const auto& [x, y] : std::vector<std::pair<int, int>>{
           {10, 10}, {11, 11}, {9, 10}, {30, 10}, {31, 9}, {30, 20}}) {
    EXPECT_FALSE(SeenThrough(seen, At(x, y, 2.0f))) << x << "," << y;
  }
  EXPECT_TRUE(SeenThrough(seen, At(12, 10, 2.0f)));  // two pixels away
  EXPECT_EQ(Look(seen, At(11, 11, 2.0f)), Sight::kUnknown);
}

TEST(FreeSpaceTest, APointByADepthEdgeIsNotTakenForOneSeenThrough) {
  // Left half a near wall at 2, right half a far one at 6.
  cv::Mat depth(kHeight, kWidth, CV_32FC1, 6.0f);
  depth.colRange(0, 20).setTo(2.0f);
  const std::vector<SeenDepth> seen = {MakeSeenDepth(Camera(), depth)};
  // On the near wall's edge, landing a pixel over the edge: not seen through.
  EXPECT_FALSE(SeenThrough(seen, At(20, 15, 2.0f)));
  // Two pixels over the edge it is in front of the far wall.
  EXPECT_TRUE(SeenThrough(seen, At(21, 15, 2.0f)));
  EXPECT_TRUE(SeenThrough(seen, At(30, 15, 5.0f)));
}

TEST(FreeSpaceTest, AnyViewSuffices) {
  RasterCamera moved = Camera();
  moved.translation = Eigen::Vector3f(0, 0, 1);  // a step back
  const std::vector<SeenDepth> seen = {
      MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, 1.0f)),
      MakeSeenDepth(moved, cv::Mat(kHeight, kWidth, CV_32FC1, 5.0f))};
  // Behind the first view's surface at 1, in front of the second's at 4.
  EXPECT_TRUE(SeenThrough(seen, At(20, 15, 3.0f)));
  EXPECT_FALSE(SeenThrough(seen, At(20, 15, 3.9f)));
  EXPECT_EQ(Look(seen, At(20, 15, 3.9f)), Sight::kOnSurface);
  EXPECT_EQ(Look(seen, At(20, 15, 9.0f)), Sight::kUnseen);  // behind both
}

// A warp shows one frame's content in another camera, none of what other
// frames saw: it is trusted to see through only what no frame saw.
TEST(FreeSpaceTest, AWarpClearsOnlyWhatNoFrameSaw) {
  RasterCamera side = Camera();  // at x = 1.5: sees x from -0.7 to 3.7 at 4
  side.translation = Eigen::Vector3f(-1.5f, 0, 0);
  const std::vector<SeenDepth> frames = {
      MakeSeenDepth(side, cv::Mat(kHeight, kWidth, CV_32FC1, 4.0f))};
  const std::vector<SeenDepth> warps = {
      MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, 6.0f))};
  const Eigen::Vector3f on_frame_surface(1.5f, 0, 4);   // the frame saw it
  const Eigen::Vector3f in_front_of_frame(1.5f, 0, 2);  // the frame saw past
  const Eigen::Vector3f unseen(-1.0f, 0, 3);            // out of the frame
  const Eigen::Vector3f behind_the_warp(-1.0f, 0, 7);   // hidden from both
  std::vector<float> xyz;
  for (const Eigen::Vector3f& p :
       {on_frame_surface, in_front_of_frame, unseen, behind_the_warp})
    xyz.insert(xyz.end(), p.data(), p.data() + 3);
  ASSERT_TRUE(SeenThrough(warps, on_frame_surface));
  EXPECT_EQ(InFreeSpace(frames, warps, xyz.data(), 4),
            (std::vector<std::uint8_t>{0, 1, 1, 0}));
  // Without expanded views only the frame's free space is known.
  EXPECT_EQ(InFreeSpace(frames, {}, xyz.data(), 4),
            (std::vector<std::uint8_t>{0, 1, 0, 0}));
  // A frame without depth where the point lands (a stereo hole) may have
  // seen it: the warp does not decide there.
  RasterCamera wide = Camera();
  wide.translation = Eigen::Vector3f(1.0f, 0, 2.0f);  // sees `unseen`
  cv::Mat holey(kHeight, kWidth, CV_32FC1, 1.0f);
  holey.colRange(10, 30).setTo(0.0f);
  const std::vector<SeenDepth> with_hole = {frames[0],
                                            MakeSeenDepth(wide, holey)};
  ASSERT_EQ(Look(with_hole, unseen), Sight::kUnknown);
  EXPECT_EQ(InFreeSpace(with_hole, warps, xyz.data(), 4),
            (std::vector<std::uint8_t>{0, 1, 0, 0}));
}

// Where the depth is the prior's guess, the expanded views vote: a point is
// cleared when more than kFreeSpaceVotes times as many see through it as
// have it on their surface.
TEST(FreeSpaceTest, GuessedDepthClearsAPointByAMajority) {
  const cv::Mat guessed(kHeight, kWidth, CV_8UC1, cv::Scalar(255));
  const auto view = [&](float depth) {
    return MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, depth),
                         guessed);
  };
  const Eigen::Vector3f p = At(20, 15, 3.0f);
  const auto empty = [&](int through, int on) {
    std::vector<SeenDepth> expanded;
    for (int k = 0; k < through; ++k) expanded.push_back(view(5.0f));
    for (int k = 0; k < on; ++k) expanded.push_back(view(3.0f));
    for (int k = 0; k < 3; ++k) expanded.push_back(view(2.0f));  // behind
    return InFreeSpace({}, expanded, p.data(), 1)[0] == 1;
  };
  EXPECT_FALSE(empty(0, 0));
  EXPECT_TRUE(empty(1, 0));
  EXPECT_FALSE(empty(kFreeSpaceVotes, 1));
  EXPECT_TRUE(empty(kFreeSpaceVotes + 1, 1));
  EXPECT_FALSE(empty(2 * kFreeSpaceVotes, 2));
  // Observed depth (a warp) needs no majority.
  std::vector<SeenDepth> expanded = {
      MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, 5.0f))};
  for (int k = 0; k < 3; ++k) expanded.push_back(view(3.0f));
  EXPECT_EQ(InFreeSpace({}, expanded, p.data(), 1)[0], 1);
  // Next to a guess, depth counts as guessed.
  cv::Mat one_guess(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  one_guess.at<std::uint8_t>(15, 21) = 255;
  expanded[0] = MakeSeenDepth(
      Camera(), cv::Mat(kHeight, kWidth, CV_32FC1, 5.0f), one_guess);
  EXPECT_EQ(InFreeSpace({}, expanded, p.data(), 1)[0], 0);
}

TEST(FreeSpaceTest, TheSpaceAroundAVideoCameraIsEmptyUnlessAFrameSawASurface) {
  // The nearest thing the frame saw is 2.0 away (a few wrong pixels at 0.5
  // do not shrink the ball: it is taken at the 2nd percentile).
  cv::Mat depth(kHeight, kWidth, CV_32FC1, 4.0f);
  depth(cv::Rect(0, 20, kWidth, 10)) = 2.0f;
  depth.at<float>(0, 0) = 0.5f;
  EXPECT_FLOAT_EQ(CameraClearance(depth), kCameraClearance * 2.0f);
  EXPECT_EQ(CameraClearance(cv::Mat(kHeight, kWidth, CV_32FC1, 0.0f)), 0.0f);
  SeenDepth frame = MakeSeenDepth(Camera(), depth);
  frame.clearance = CameraClearance(depth);
  // Beside and behind the camera, outside its image: no frame saw there.
  const std::vector<Eigen::Vector3f> points = {
      {1.0f, 0.0f, 0.0f},
      {0.0f, 0.0f, -1.0f},
      {0.0f, 1.2f, 0.3f},
      {3.0f, 0.0f, 0.0f}};  // the last is outside the ball
  std::vector<float> xyz;
  for (const Eigen::Vector3f& p : points)
    xyz.insert(xyz.end(), p.data(), p.data() + 3);
  std::vector<std::uint8_t> empty =
      InFreeSpace({frame}, {}, xyz.data(), points.size());
  EXPECT_EQ(empty, (std::vector<std::uint8_t>{1, 1, 1, 0}));
  // A second frame beside the first that has the first point on its
  // surface keeps it: what a frame observed wins over the ball.
  RasterCamera side = Camera();
  side.translation = Eigen::Vector3f(-1.0f, 0.0f, 1.0f);  // centre (1, 0, -1)
  const SeenDepth other =
      MakeSeenDepth(side, cv::Mat(kHeight, kWidth, CV_32FC1, 1.0f));
  empty = InFreeSpace({frame, other}, {}, xyz.data(), 1);
  EXPECT_EQ(empty[0], 0);
  // Without the ball nothing is claimed there.
  frame.clearance = 0;
  empty = InFreeSpace({frame}, {}, xyz.data(), points.size());
  EXPECT_EQ(empty, (std::vector<std::uint8_t>{0, 0, 0, 0}));
}

// The floor below a camera lies in its clearance ball, out of its view: on
// a fitted plane only a frame that sees through a point empties it.
TEST(FreeSpaceTest, AFittedPlaneIsEmptyOnlyWhereAFrameSeesThroughIt) {
  const cv::Mat wall(kHeight, kWidth, CV_32FC1, 4.0f);
  SeenDepth frame = MakeSeenDepth(Camera(), wall);
  frame.clearance = CameraClearance(wall);
  const Eigen::Vector3f through = At(20, 25, 3.0f);  // 25% before the wall
  const float floor_y = through.y();                 // image y points down
  Layout layout;
  layout.valid = true;
  layout.lo = Eigen::Vector3f(-5, -3, -5);
  layout.hi = Eigen::Vector3f(5, floor_y, 8);
  layout.on_plane[3] = true;  // +y: the floor
  const std::vector<Eigen::Vector3f> points = {
      {0.0f, floor_y, 0.3f},         // on the floor, below the camera
      through,                       // on the floor, seen through
      {0.0f, floor_y - 0.5f, 0.3f},  // in the ball, above the floor
      {0.0f, floor_y, 6.0f}};        // on the floor behind the wall
  ASSERT_LT(points[0].norm(), frame.clearance);
  ASSERT_EQ(Look({frame}, points[0]), Sight::kUnseen);
  std::vector<float> xyz;
  for (const Eigen::Vector3f& p : points)
    xyz.insert(xyz.end(), p.data(), p.data() + 3);
  EXPECT_EQ(InFreeSpace({frame}, {}, xyz.data(), points.size()),
            (std::vector<std::uint8_t>{1, 1, 1, 0}));
  EXPECT_EQ(InFreeSpace({frame}, {}, xyz.data(), points.size(), &layout, 0.05f),
            (std::vector<std::uint8_t>{0, 1, 1, 0}));
  // Nor does an expanded view's warp that sees through the floor where no
  // frame saw (a camera 2 behind the first point, looking at it), which
  // empties it off the plane.
  frame.clearance = 0;
  RasterCamera behind = Camera();
  behind.translation = -(points[0] - Eigen::Vector3f(0, 0, 2));
  const SeenDepth warp = MakeSeenDepth(behind, wall);
  ASSERT_EQ(Look({warp}, points[0]), Sight::kSeenThrough);
  EXPECT_EQ(InFreeSpace({frame}, {warp}, xyz.data(), 1)[0], 1);
  EXPECT_EQ(InFreeSpace({frame}, {warp}, xyz.data(), 1, &layout, 0.05f)[0], 0);
}

TEST(FreeSpaceTest, DepthOfAnotherSizeOrTypeIsAnError) {
  EXPECT_THROW(
      MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth + 1, CV_32FC1, 1.0f)),
      Error);
  EXPECT_THROW(MakeSeenDepth(Camera(), cv::Mat(kHeight, kWidth, CV_64FC1, 1.0)),
               Error);
  const cv::Mat depth(kHeight, kWidth, CV_32FC1, 1.0f);
  EXPECT_THROW(MakeSeenDepth(Camera(), depth, cv::Mat(kHeight, 3, CV_8UC1)),
               Error);
  EXPECT_THROW(
      MakeSeenDepth(Camera(), depth, cv::Mat(kHeight, kWidth, CV_32FC1)),
      Error);
}

}  // namespace
}  // namespace pano4d
