#include "evaluation/metrics.h"

#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/npy.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// Vectors made by tests/data/metrics/make_vectors.py: scikit-image for the
// unmasked metrics, a NumPy port of DyCheck's code for the masked ones.
const std::filesystem::path kVectors =
    std::filesystem::path(PANO4D_SOURCE_DIR) / "tests/data/metrics";
constexpr double kTolerance = 1e-5;

Image FromUint8(const NpyArray& array) {
  const int h = static_cast<int>(array.shape[0]),
            w = static_cast<int>(array.shape[1]);
  Image image(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) {
        image.at(x, y)[c] = array.data[(y * w + x) * 3 + c] / 255.0f;
      }
    }
  }
  return image;
}

cv::Mat MaskFromUint8(const NpyArray& array) {
  cv::Mat m(static_cast<int>(array.shape[0]), static_cast<int>(array.shape[1]),
            CV_8UC1);
  std::memcpy(m.data, array.data.data(), array.data.size());
  return MetricMask(m * 255, "mask.npy");
}

class MetricsVectorTest : public ::testing::TestWithParam<std::string> {};

TEST_P(MetricsVectorTest, MatchesScikitImageAndDyCheck) {
  const std::string name = GetParam();
  const Json expected = ReadJson(kVectors / "expected.json")[name];
  const cv::Mat a =
      QuantizeForMetrics(FromUint8(ReadNpy(kVectors / (name + "_a.npy"))), "a");
  const cv::Mat b =
      QuantizeForMetrics(FromUint8(ReadNpy(kVectors / (name + "_b.npy"))), "b");
  const cv::Mat mask = MaskFromUint8(ReadNpy(kVectors / "mask.npy"));
  const cv::Mat unseen = InvertMask(mask);

  EXPECT_NEAR(*Psnr(a, b), expected["psnr"].get<double>(), kTolerance);
  EXPECT_NEAR(Ssim(a, b)->dycheck, expected["ssim"].get<double>(), kTolerance);
  EXPECT_NEAR(Ssim(a, b)->strict, expected["ssim"].get<double>(), kTolerance);
  EXPECT_NEAR(*Psnr(a, b, mask), expected["masked_psnr"].get<double>(),
              kTolerance);
  EXPECT_NEAR(Ssim(a, b, mask)->dycheck, expected["masked_ssim"].get<double>(),
              kTolerance);
  EXPECT_NEAR(Ssim(a, b, mask)->strict,
              expected["masked_ssim_strict"].get<double>(), kTolerance);
  EXPECT_NEAR(*Psnr(a, b, unseen), expected["unseen_psnr"].get<double>(),
              kTolerance);
  EXPECT_NEAR(Ssim(a, b, unseen)->dycheck,
              expected["unseen_ssim"].get<double>(), kTolerance);
  EXPECT_NEAR(Ssim(a, b, unseen)->strict,
              expected["unseen_ssim_strict"].get<double>(), kTolerance);
}

INSTANTIATE_TEST_SUITE_P(Vectors, MetricsVectorTest,
                         ::testing::Values("flat", "noisy", "smooth",
                                           "extreme"));

TEST(MetricsTest, QuantisationRecoversEveryEightBitLevelFromAPng) {
  testing::TempDir dir;
  Image levels(256, 1);
  for (int k = 0; k < 256; ++k)
    levels.at(k, 0) = cv::Vec3f(k / 255.0f, k / 255.0f, k / 255.0f);
  WriteImage(dir / "levels.png", levels);
  const cv::Mat q =
      QuantizeForMetrics(ReadImage(dir / "levels.png"), "levels.png");
  for (int k = 0; k < 256; ++k)
    EXPECT_EQ(q.at<cv::Vec3d>(0, k)[0], k / 255.0) << k;

  Image odd(3, 1);
  odd.at(0, 0) = cv::Vec3f(1.7f, -0.2f, 0.99999f);  // clip, clip, truncate
  const cv::Vec3d v = QuantizeForMetrics(odd, "odd").at<cv::Vec3d>(0, 0);
  EXPECT_EQ(v[0], 1.0);
  EXPECT_EQ(v[1], 0.0);
  EXPECT_EQ(v[2], 254.0 / 255.0);
}

TEST(MetricsTest, DefinedValuesAtTheEdges) {
  cv::Mat a(20, 24, CV_64FC3, cv::Scalar(0.2, 0.4, 0.6));
  cv::Mat b = a.clone();
  EXPECT_TRUE(std::isinf(*Psnr(a, b)));  // identical: +inf dB
  EXPECT_DOUBLE_EQ(Ssim(a, b)->dycheck, 1.0);

  const cv::Mat empty(a.size(), CV_64FC1, cv::Scalar(0.0));
  EXPECT_FALSE(Psnr(a, b, empty).has_value());  // undefined, not a number
  EXPECT_FALSE(Ssim(a, b, empty).has_value());
  b.at<cv::Vec3d>(5, 5) = cv::Vec3d(1, 1, 1);
  const cv::Mat full(a.size(), CV_64FC1, cv::Scalar(1.0));
  EXPECT_DOUBLE_EQ(*Psnr(a, b, full), *Psnr(a, b));
  EXPECT_NEAR(Ssim(a, b, full)->dycheck, Ssim(a, b)->dycheck, 1e-12);
}

TEST(MetricsTest, BadInputsAreErrors) {
  const cv::Mat a(20, 24, CV_64FC3, cv::Scalar::all(0.5));
  EXPECT_THROW(Psnr(a, cv::Mat(20, 25, CV_64FC3, cv::Scalar::all(0.5))), Error);
  EXPECT_THROW(Psnr(a, a, cv::Mat(19, 24, CV_64FC1, cv::Scalar(1.0))), Error);
  EXPECT_THROW(Psnr(a, cv::Mat(20, 24, CV_32FC3)), Error);
  const cv::Mat small(8, 24, CV_64FC3, cv::Scalar::all(0.5));
  EXPECT_THROW(Ssim(small, small), Error);
  Image nan_image(4, 4);
  nan_image.at(1, 2)[0] = std::nanf("");
  try {
    QuantizeForMetrics(nan_image, "renders/1_00003.png");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "renders/1_00003.png");
  }
}

}  // namespace
}  // namespace pano4d
