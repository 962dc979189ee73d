#include "src/geometry/tracks.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"

namespace pano4d {
namespace {

// A smooth random texture, 8-bit grey.
cv::Mat Texture(int width, int height, unsigned seed) {
  cv::Mat noise(height, width, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 2.0);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  cv::Mat out;
  smooth.convertTo(out, CV_8U);
  return out;
}

cv::Mat Shifted(const cv::Mat& image, double dx, double dy) {
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::Mat out;
  cv::warpAffine(image, out, m, image.size(), cv::INTER_LINEAR,
                 cv::BORDER_REFLECT);
  return out;
}

TEST(TracksTest, FollowATranslatingTextureBothWays) {
  const cv::Mat base = Texture(160, 120, 1);
  std::vector<cv::Mat> frames;
  for (int t = 0; t < 7; ++t)
    frames.push_back(Shifted(base, 1.5 * t, -0.5 * t));
  std::vector<Eigen::Vector2f> seeds;
  for (int y = 30; y < 90; y += 10)
    for (int x = 40; x < 120; x += 10) seeds.emplace_back(x + 0.5f, y + 0.5f);
  const Tracks2D tracks = ChainFlowTracks(frames, 3, seeds);
  ASSERT_EQ(tracks.size(), seeds.size());
  int checked = 0;
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    for (int t = 0; t < 7; ++t) {
      ASSERT_TRUE(tracks.is_valid(i, t)) << i << " " << t;
      const Eigen::Vector2f expected =
          seeds[i] + Eigen::Vector2f(1.5f * (t - 3), -0.5f * (t - 3));
      EXPECT_LT((tracks.pixel(i, t) - expected).norm(), 0.5f)
          << "track " << i << " time " << t;
      ++checked;
    }
  }
  EXPECT_EQ(checked, static_cast<int>(seeds.size()) * 7);
}

// Chained over 24 links, each link's sub-pixel error adds up: flow computed
// at a coarser scale than the frames drifts by pixels over such a chain (the
// motion initialisation lifts these tracks 24 frames from the canonical
// time). A fine texture, as a small frame of a real scene shows.
TEST(TracksTest, LongChainsDoNotDrift) {
  cv::Mat base = Texture(480, 360, 4);
  cv::resize(base, base, cv::Size(240, 180), 0, 0, cv::INTER_AREA);
  constexpr int kFrames = 25;
  constexpr float kDx = 0.7f, kDy = 0.3f;
  std::vector<cv::Mat> frames;
  for (int t = 0; t < kFrames; ++t)
    frames.push_back(Shifted(base, kDx * t, kDy * t));
  std::vector<Eigen::Vector2f> seeds;
  for (int y = 50; y < 130; y += 8)
    for (int x = 40; x < 180; x += 8) seeds.emplace_back(x + 0.5f, y + 0.5f);
  const Tracks2D tracks = ChainFlowTracks(frames, 0, seeds);
  std::vector<float> errors;
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    if (!tracks.is_valid(i, kFrames - 1)) continue;
    const Eigen::Vector2f expected =
        seeds[i] + (kFrames - 1) * Eigen::Vector2f(kDx, kDy);
    errors.push_back((tracks.pixel(i, kFrames - 1) - expected).norm());
  }
  ASSERT_GT(errors.size(), tracks.size() * 3 / 4);
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.5f);
  EXPECT_LT(errors[errors.size() * 9 / 10], 1.0f);
}

TEST(TracksTest, ATrackEndsWhereItsPointIsCoveredAndAtAMissingFrame) {
  const cv::Mat base = Texture(160, 120, 2);
  std::vector<cv::Mat> frames = {base.clone(), base.clone(), base.clone(),
                                 cv::Mat(), base.clone()};
  // Frame 2 has the left half replaced by another texture: the seeds there
  // cannot be followed consistently.
  Texture(160, 120, 3)(cv::Rect(0, 0, 80, 120))
      .copyTo(frames[2](cv::Rect(0, 0, 80, 120)));
  const std::vector<Eigen::Vector2f> seeds = {{20.5f, 60.5f}, {130.5f, 60.5f}};
  const Tracks2D tracks = ChainFlowTracks(frames, 0, seeds);
  EXPECT_TRUE(tracks.is_valid(0, 1));
  EXPECT_FALSE(tracks.is_valid(0, 2));  // covered
  EXPECT_TRUE(tracks.is_valid(1, 2));   // untouched right half
  EXPECT_FALSE(tracks.is_valid(1, 3));  // no frame
  EXPECT_FALSE(tracks.is_valid(1, 4));  // a broken track stays broken
}

TEST(TracksTest, BadInputIsAnError) {
  const cv::Mat base = Texture(64, 48, 4);
  EXPECT_THROW(ChainFlowTracks({base, cv::Mat()}, 1, {}), Error);
  EXPECT_THROW(ChainFlowTracks({base, Texture(32, 24, 5)}, 0, {}), Error);
  EXPECT_THROW(ChainFlowTracks({base}, 0, {}, {.consistency_threshold = 0}),
               Error);
}

}  // namespace
}  // namespace pano4d
