#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace pano4d {

// An RGB image in memory: float32, channels in R, G, B order, values in
// [0, 1] for ordinary (LDR) images; EXR images may exceed 1. Backed by a
// cv::Mat of type CV_32FC3, so OpenCV functions apply directly to mat();
// OpenCV's BGR order exists only at the file boundary (ReadImage/WriteImage).
class Image {
 public:
  Image() = default;
  Image(int width, int height);  // black

  // Wraps a CV_32FC3 RGB matrix (shares its data). Throws pano4d::Error if
  // the type is different.
  static Image FromRgb32f(cv::Mat rgb);
  // Converts an OpenCV image as imread returns it: 8-bit, 16-bit or float,
  // with 1 (grey), 3 (BGR) or 4 (BGRA, alpha dropped) channels.
  static Image FromOpenCV(const cv::Mat& bgr_or_grey,
                          const std::string& source);

  int width() const { return mat_.cols; }
  int height() const { return mat_.rows; }
  bool empty() const { return mat_.empty(); }
  const cv::Mat& mat() const { return mat_; }
  cv::Mat& mat() { return mat_; }
  cv::Vec3f& at(int x, int y) { return mat_.at<cv::Vec3f>(y, x); }
  const cv::Vec3f& at(int x, int y) const { return mat_.at<cv::Vec3f>(y, x); }

  // 8-bit BGR for OpenCV encoders and windows: clamped to [0, 1] and rounded.
  cv::Mat ToBgr8() const;
  // True when no pixel is NaN or infinite.
  bool AllFinite() const;

 private:
  cv::Mat mat_;  // CV_32FC3, RGB
};

// Decodes PNG, JPEG or EXR (anything OpenCV's imgcodecs reads). `source`
// names the input in errors. A file that is truncated (a PNG without its
// IEND chunk, a JPEG without its end-of-image marker) is an error, not an
// image with a grey tail. The optional `alpha` receives the alpha channel of
// RGBA inputs as CV_32FC1 in [0, 1] (empty if there is none).
Image DecodeImage(const std::vector<std::uint8_t>& bytes,
                  const std::string& source, cv::Mat* alpha = nullptr);
Image ReadImage(const std::filesystem::path& path, cv::Mat* alpha = nullptr);

// Encodes by extension: .png and .jpg/.jpeg as 8 bits (JPEG quality 95),
// .exr as 32-bit float. Throws pano4d::Error if the image has NaN or Inf (a
// silent NaN would become a black pixel), or the extension is unknown.
std::vector<std::uint8_t> EncodeImage(const Image& image,
                                      const std::string& extension,
                                      const std::string& destination);
// Writes atomically (temporary name, then rename).
void WriteImage(const std::filesystem::path& path, const Image& image);

// OpenCV headers over pano4d's row-major buffers (a TrainingView's, a
// RenderOutput's): H x W x `channels` floats (CV_32FC<channels>) or H x W
// bytes (CV_8UC1), without a copy. Valid while `data` lives and keeps its
// size; read-only by contract (OpenCV has no const header), so a caller
// that writes clones first. Throws pano4d::Error when the size does not
// match (an empty buffer gives an empty header).
cv::Mat MatView(const std::vector<float>& data, int height, int width,
                int channels = 1);
cv::Mat MatView(const std::vector<std::uint8_t>& data, int height, int width);

// Masks across every module boundary are CV_8UC1 (or bytes) with 0 = no and
// 255 = yes, as the files hold them (DESIGN.md); readers take any nonzero
// value as yes.
inline constexpr std::uint8_t kMaskOn = 255;

// Single-channel 8-bit images: masks (0 or 255, DESIGN.md) and label maps
// (instance ids). ReadMask takes the first channel of whatever the file
// holds, converted to 8 bits; WriteMask needs a CV_8UC1 matrix and writes a
// lossless PNG atomically.
cv::Mat ReadMask(const std::filesystem::path& path);
void WriteMask(const std::filesystem::path& path, const cv::Mat& mask);
// An 8-bit grey or BGR matrix (OpenCV's own order, e.g. a plot drawn with
// OpenCV) as a lossless PNG, written atomically.
void WritePng8(const std::filesystem::path& path, const cv::Mat& image);

}  // namespace pano4d
