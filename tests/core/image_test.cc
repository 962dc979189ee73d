#include "src/core/image.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

using testing::TempDir;

Image Gradient(int width, int height) {
  Image image(width, height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.at(x, y) =
          cv::Vec3f(float(x) / (width - 1), float(y) / (height - 1), 0.25f);
    }
  }
  return image;
}

double MaxAbsDiff(const Image& a, const Image& b) {
  return cv::norm(a.mat(), b.mat(), cv::NORM_INF);
}

std::string ErrorOf(const std::filesystem::path& path) {
  try {
    ReadImage(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(ImageTest, PngRoundTripWithinQuantisation) {
  TempDir dir;
  const Image image = Gradient(64, 48);
  WriteImage(dir / "a.png", image);
  const Image back = ReadImage(dir / "a.png");
  ASSERT_EQ(back.width(), 64);
  ASSERT_EQ(back.height(), 48);
  EXPECT_LE(MaxAbsDiff(image, back), 0.5 / 255 + 1e-6);
}

TEST(ImageTest, ExrRoundTripIsExactAndKeepsHighValues) {
  TempDir dir;
  Image image = Gradient(16, 8);
  image.at(3, 2) = cv::Vec3f(7.5f, -0.25f, 1e-5f);
  WriteImage(dir / "a.exr", image);
  EXPECT_EQ(MaxAbsDiff(image, ReadImage(dir / "a.exr")), 0.0);
}

TEST(ImageTest, JpegRoundTripIsClose) {
  TempDir dir;
  const Image image = Gradient(64, 48);
  WriteImage(dir / "a.jpg", image);
  cv::Mat diff;
  cv::absdiff(image.mat(), ReadImage(dir / "a.jpg").mat(), diff);
  EXPECT_LT(cv::mean(diff)[0], 0.02);
}

TEST(ImageTest, ChannelsAreRgbInMemoryAndBgrOnDisk) {
  TempDir dir;
  Image red(4, 4);
  red.mat().setTo(cv::Scalar(1, 0, 0));
  WriteImage(dir / "red.png", red);
  const cv::Mat raw =
      cv::imread((dir / "red.png").string(), cv::IMREAD_UNCHANGED);
  EXPECT_EQ(raw.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(ReadImage(dir / "red.png").at(1, 1), cv::Vec3f(1, 0, 0));
}

TEST(ImageTest, AlphaAndSixteenBitInputs) {
  TempDir dir;
  cv::Mat bgra(2, 3, CV_8UC4, cv::Scalar(255, 0, 0, 128));
  cv::imwrite((dir / "rgba.png").string(), bgra);
  cv::Mat alpha;
  const Image image = ReadImage(dir / "rgba.png", &alpha);
  EXPECT_EQ(image.at(0, 0), cv::Vec3f(0, 0, 1));
  ASSERT_EQ(alpha.type(), CV_32FC1);
  EXPECT_NEAR(alpha.at<float>(1, 2), 128.0 / 255, 1e-7);

  cv::Mat grey16(2, 2, CV_16UC1, cv::Scalar(65535));
  cv::imwrite((dir / "g16.png").string(), grey16);
  EXPECT_EQ(ReadImage(dir / "g16.png").at(1, 1), cv::Vec3f(1, 1, 1));
}

TEST(ImageTest, TruncatedPngIsAnErrorNamingTheFile) {
  TempDir dir;
  testing::WriteTruncatedPng(dir / "cut.png");
  const std::string message = ErrorOf(dir / "cut.png");
  EXPECT_EQ(message.rfind((dir / "cut.png").string() + ": truncated PNG", 0),
            0u)
      << message;
}

TEST(ImageTest, TruncatedJpegIsAnError) {
  TempDir dir;
  const std::vector<std::uint8_t> bytes =
      EncodeImage(Gradient(64, 48), ".jpg", "mem");
  {
    std::ofstream out(dir / "cut.jpg", std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              bytes.size() * 2 / 3);
  }
  EXPECT_NE(ErrorOf(dir / "cut.jpg").find("truncated JPEG"), std::string::npos);
}

TEST(ImageTest, GarbageEmptyAndMissingFilesAreErrors) {
  TempDir dir;
  testing::WriteText(dir / "text.png", "this is not an image at all");
  testing::WriteText(dir / "empty.png", "");
  EXPECT_NE(ErrorOf(dir / "text.png").find("cannot be decoded"),
            std::string::npos);
  EXPECT_NE(ErrorOf(dir / "empty.png").find("is empty"), std::string::npos);
  EXPECT_NE(ErrorOf(dir / "missing.png").find("does not exist"),
            std::string::npos);
}

TEST(ImageTest, NonFiniteImagesAreNotWritten) {
  TempDir dir;
  Image image = Gradient(8, 8);
  image.at(2, 3)[1] = std::nanf("");
  EXPECT_FALSE(image.AllFinite());
  EXPECT_THROW(WriteImage(dir / "nan.png", image), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "nan.png"));
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
  EXPECT_THROW(WriteImage(dir / "a.bmpx", Gradient(4, 4)), Error);
}

TEST(ImageTest, WrapsOnlyFloatRgb) {
  EXPECT_THROW(Image::FromRgb32f(cv::Mat(2, 2, CV_8UC3)), Error);
  const Image image =
      Image::FromRgb32f(cv::Mat(2, 3, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5)));
  EXPECT_EQ(image.width(), 3);
  EXPECT_EQ(image.height(), 2);
}

}  // namespace
}  // namespace pano4d
