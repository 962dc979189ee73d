#include "src/pano/pairs.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/render/bench_scene.h"
#include "src/render/rasterizer.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

std::vector<TrainingView> Views(int count) {
  const GaussianModel scene =
      RandomViewFillingScene(800, BenchCamera(48, 36), 3.0f, 7);
  std::vector<TrainingView> views;
  Rasterizer rasterizer;
  RenderOutput out;
  for (int t = 0; t < count; ++t) {
    TrainingView v;
    v.name = "f";
    v.name +=
        std::to_string(t);  // GCC 12: no "literal" + string&& (-Wrestrict)
    v.time = t;
    v.camera = BenchCamera(48, 36);
    v.camera.translation.x() = -0.05f * t;
    rasterizer.Render(scene, v.camera, {}, &out);
    v.rgb = out.rgb;
    v.depth = out.depth;
    views.push_back(std::move(v));
  }
  return views;
}

TEST(PairsTest, CovisibleVideoIsTheSourceWhereTheRoundTripKeptIt) {
  testing::TempDir dir;
  PairOptions o;
  o.frames = 4;
  o.elevation_degrees = 20;
  const PairsReport r = MakeTrainingPairs(Views(5), o, dir.path());
  EXPECT_EQ(r.clips, 1);
  EXPECT_EQ(r.frames_per_clip, 4);
  const std::filesystem::path clip = dir / "clip_00000";
  // Frame 0 has not moved: the round trip is the identity.
  EXPECT_EQ(cv::countNonZero(ReadMask(clip / "mask" / "00000.png")), 0);
  // The last one has turned 20 degrees: it loses pixels, and what it keeps
  // is the source's colour.
  const cv::Mat mask = ReadMask(clip / "mask" / "00003.png");
  EXPECT_GT(cv::countNonZero(mask), 0);
  EXPECT_LT(cv::countNonZero(mask), static_cast<int>(mask.total()));
  const cv::Mat cov = ReadImage(clip / "cov" / "00003.png").mat();
  const cv::Mat src = ReadImage(clip / "src" / "00003.png").mat();
  cv::Mat diff;
  cv::absdiff(cov, src, diff);
  // Two splats blur a random Gaussian scene a little; black instead of the
  // source would be off by the scene's mean colour.
  EXPECT_LT(cv::mean(diff, mask == 0)[0], 0.08);
  EXPECT_GT(cv::mean(src, mask == 0)[0], 0.2);
}

TEST(PairsTest, RefusesFramesWithoutDepthAndBadOptions) {
  testing::TempDir dir;
  std::vector<TrainingView> views = Views(3);
  views[1].depth.clear();
  EXPECT_THROW(MakeTrainingPairs(views, PairOptions(), dir.path()), Error);
  PairOptions o;
  o.elevation_degrees = 0;
  EXPECT_THROW(o.Check(), Error);
  o = PairOptions();
  o.frames = 1;
  EXPECT_THROW(o.Check(), Error);
}

}  // namespace
}  // namespace pano4d
