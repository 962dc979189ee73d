#include "evaluation/lpips.h"

#include <limits>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/npy.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// Reference outputs of tests/data/lpips/make_reference.py: LPIPS's forward
// pass in torch on a narrow network with AlexNet's exact topology.
const std::filesystem::path kFixture =
    std::filesystem::path(PANO4D_SOURCE_DIR) / "tests/data/lpips";
// float32 convolutions summed in another order than torch's.
constexpr double kTolerance = 1e-5;

cv::Mat Image01(const NpyArray& array) {
  const int h = static_cast<int>(array.shape[0]),
            w = static_cast<int>(array.shape[1]);
  cv::Mat out(h, w, CV_64FC3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c)
        out.at<cv::Vec3d>(y, x)[c] = array.data[(y * w + x) * 3 + c] / 255.0;
    }
  }
  return out;
}

TEST(LpipsTest, MatchesTheTorchReference) {
  const Lpips lpips = Lpips::Load(kFixture);
  const Json expected = ReadJson(kFixture / "expected.json");
  const cv::Mat a = Image01(ReadNpy(kFixture / "a.npy"));
  const cv::Mat b = Image01(ReadNpy(kFixture / "b.npy"));
  const NpyArray mask_array = ReadNpy(kFixture / "mask.npy");
  cv::Mat mask(a.rows, a.cols, CV_64FC1);
  for (int i = 0; i < a.rows * a.cols; ++i)
    mask.at<double>(i / a.cols, i % a.cols) = mask_array.data[i];
  cv::Mat unseen;
  cv::subtract(cv::Scalar(1.0), mask, unseen);

  const cv::Mat map = lpips.Map(a, b);
  for (const Json& sample : expected["map_samples"]) {
    EXPECT_NEAR(map.at<double>(sample[0].get<int>(), sample[1].get<int>()),
                sample[2].get<double>(), kTolerance)
        << sample.dump();
  }
  EXPECT_NEAR(*lpips.Score(a, b), expected["lpips"].get<double>(), kTolerance);
  EXPECT_NEAR(*lpips.Score(a, b, mask), expected["lpips_masked"].get<double>(),
              kTolerance);
  EXPECT_NEAR(*lpips.Score(a, b, unseen),
              expected["lpips_unseen"].get<double>(), kTolerance);
  EXPECT_NEAR(*lpips.Score(a, a), 0.0, 1e-12);
  EXPECT_FALSE(lpips.Score(a, b, cv::Mat(a.size(), CV_64FC1, cv::Scalar(0.0)))
                   .has_value());
}

TEST(LpipsTest, MissingOrMisShapedWeightsNameTheFile) {
  testing::TempDir dir;
  try {
    Lpips::Load(dir / "nowhere");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lpips_weights_from_torch.py"),
              std::string::npos);
  }
  for (const auto& entry : std::filesystem::directory_iterator(kFixture)) {
    if (entry.path().filename().string().rfind("conv", 0) == 0 ||
        entry.path().filename().string().rfind("lin", 0) == 0) {
      std::filesystem::copy(entry.path(), dir / entry.path().filename());
    }
  }
  EXPECT_NO_THROW(Lpips::Load(dir.path()));
  std::filesystem::remove(dir / "lin3.weight.npy");
  try {
    Lpips::Load(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "lin3.weight.npy").string());
  }
  WriteNpy(dir / "lin3.weight.npy",
           NpyArray::FromFloats({1, 5, 1, 1}, {1, 1, 1, 1, 1}));
  EXPECT_THROW(Lpips::Load(dir.path()), Error);
}

// A NaN-filled network is refused at load, naming the file; a NaN image
// gives an error, not -inf in a report.
TEST(LpipsTest, NonFiniteWeightsOrScoresAreErrors) {
  testing::TempDir dir;
  for (const auto& entry : std::filesystem::directory_iterator(kFixture)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("conv", 0) == 0 || name.rfind("lin", 0) == 0)
      std::filesystem::copy(entry.path(), dir / name);
  }
  const Lpips lpips = Lpips::Load(dir.path());
  cv::Mat a(16, 16, CV_64FC3, cv::Scalar(0.5, 0.4, 0.3));
  cv::Mat b = a.clone();
  b.at<cv::Vec3d>(3, 4)[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(lpips.Score(a, b), Error);

  NpyArray lin = ReadNpy(dir / "lin2.weight.npy");
  std::vector<float> nan(lin.ToFloats().size(),
                         std::numeric_limits<float>::quiet_NaN());
  WriteNpy(dir / "lin2.weight.npy", NpyArray::FromFloats(lin.shape, nan));
  try {
    Lpips::Load(dir.path());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), (dir / "lin2.weight.npy").string());
    EXPECT_NE(std::string(e.what()).find("finite"), std::string::npos);
  }
}

}  // namespace
}  // namespace pano4d
