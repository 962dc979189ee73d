#include "src/core/image.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace {

// OpenCV 4.6 reads and writes EXR only when this variable is set before the
// codec is first used (a guard against CVEs in old OpenEXR versions; Debian
// ships a maintained OpenEXR).
void EnableOpenExr() {
  static const bool enabled = [] {
    return ::setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0) == 0;
  }();
  (void)enabled;
}

bool StartsWith(const std::vector<std::uint8_t>& bytes,
                std::initializer_list<std::uint8_t> sig) {
  return bytes.size() >= sig.size() &&
         std::equal(sig.begin(), sig.end(), bytes.begin());
}

// A PNG ends with the 12-byte IEND chunk; a JPEG ends with the EOI marker
// FF D9 (some writers pad a few bytes after it). libjpeg decodes a truncated
// file "successfully" with a grey tail, so the check must come first.
void CheckComplete(const std::vector<std::uint8_t>& bytes,
                   const std::string& source) {
  static constexpr std::array<std::uint8_t, 8> kIend = {0,   0,   0,   0,
                                                        'I', 'E', 'N', 'D'};
  if (StartsWith(bytes, {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'})) {
    if (bytes.size() < 8 + 12 ||
        !std::equal(kIend.begin(), kIend.end(), bytes.end() - 12)) {
      throw Error::In(source,
                      "truncated PNG: the IEND chunk is missing (the file is "
                      "incomplete; copy "
                      "or export it again)");
    }
  } else if (StartsWith(bytes, {0xff, 0xd8})) {
    constexpr std::size_t kMaxTrailingBytes = 64;
    const std::size_t from = bytes.size() > kMaxTrailingBytes + 2
                                 ? bytes.size() - kMaxTrailingBytes - 2
                                 : 2;
    bool found = false;
    for (std::size_t i = bytes.size() - 1; i > from && !found; --i) {
      found = bytes[i - 1] == 0xff && bytes[i] == 0xd9;
    }
    if (!found) {
      throw Error::In(
          source,
          "truncated JPEG: the end-of-image marker is missing (the file is "
          "incomplete; copy or export it again)");
    }
  }
}

double MaxValueOf(int depth) {
  switch (depth) {
    case CV_8U:
      return 255.0;
    case CV_16U:
      return 65535.0;
    default:
      return 1.0;
  }
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return s;
}

// The checked decode that every reader shares: non-empty, complete, and
// decodable, as OpenCV's IMREAD_UNCHANGED returns it.
cv::Mat DecodeRaw(const std::vector<std::uint8_t>& bytes,
                  const std::string& source) {
  EnableOpenExr();
  if (bytes.empty())
    throw Error::In(source, "is empty (0 bytes), expected an image");
  CheckComplete(bytes, source);
  cv::Mat raw = cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
  if (raw.empty()) {
    throw Error::In(
        source,
        "cannot be decoded as an image (corrupt, or not a PNG/JPEG/EXR file)");
  }
  return raw;
}

}  // namespace

Image::Image(int width, int height)
    : mat_(height, width, CV_32FC3, cv::Scalar::all(0)) {}

Image Image::FromRgb32f(cv::Mat rgb) {
  if (rgb.type() != CV_32FC3) {
    throw Error("image", "type", std::to_string(rgb.type()),
                "expected CV_32FC3 (float RGB)");
  }
  Image image;
  image.mat_ = rgb;
  return image;
}

Image Image::FromOpenCV(const cv::Mat& input, const std::string& source) {
  const int depth = input.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    throw Error(source, "depth", std::to_string(depth),
                "unsupported pixel type; expected 8-bit, 16-bit or float");
  }
  cv::Mat rgb;
  switch (input.channels()) {
    case 1:
      cv::cvtColor(input, rgb, cv::COLOR_GRAY2RGB);
      break;
    case 3:
      cv::cvtColor(input, rgb, cv::COLOR_BGR2RGB);
      break;
    case 4:
      cv::cvtColor(input, rgb, cv::COLOR_BGRA2RGB);
      break;
    default:
      throw Error(source, "channels", std::to_string(input.channels()),
                  "expected 1, 3 or 4 channels");
  }
  Image image;
  rgb.convertTo(image.mat_, CV_32F, 1.0 / MaxValueOf(depth));
  return image;
}

cv::Mat Image::ToBgr8() const {
  cv::Mat bgr, out;
  cv::cvtColor(mat_, bgr, cv::COLOR_RGB2BGR);
  // convertTo saturates to [0, 255] and rounds to nearest.
  bgr.convertTo(out, CV_8U, 255.0);
  return out;
}

bool Image::AllFinite() const {
  return mat_.empty() || cv::checkRange(mat_, true);
}

Image DecodeImage(const std::vector<std::uint8_t>& bytes,
                  const std::string& source, cv::Mat* alpha) {
  const cv::Mat raw = DecodeRaw(bytes, source);
  if (alpha) {
    *alpha = cv::Mat();
    if (raw.channels() == 4) {
      cv::Mat channel;
      cv::extractChannel(raw, channel, 3);
      channel.convertTo(*alpha, CV_32F, 1.0 / MaxValueOf(raw.depth()));
    }
  }
  return Image::FromOpenCV(raw, source);
}

Image ReadImage(const std::filesystem::path& path, cv::Mat* alpha) {
  return DecodeImage(ReadFileBytes(path), path.string(), alpha);
}

std::vector<std::uint8_t> EncodeImage(const Image& image,
                                      const std::string& extension,
                                      const std::string& destination) {
  EnableOpenExr();
  if (image.empty())
    throw Error::In(destination, "cannot write an empty image");
  if (!image.AllFinite()) {
    throw Error::In(destination,
                    "image has NaN or infinite pixels; refusing to write it");
  }
  const std::string ext = Lower(extension);
  cv::Mat encoded_input;
  std::vector<int> flags;
  if (ext == ".png") {
    encoded_input = image.ToBgr8();
  } else if (ext == ".jpg" || ext == ".jpeg") {
    encoded_input = image.ToBgr8();
    flags = {cv::IMWRITE_JPEG_QUALITY, 95};
  } else if (ext == ".exr") {
    cv::cvtColor(image.mat(), encoded_input, cv::COLOR_RGB2BGR);
    flags = {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT};
  } else {
    throw Error(destination, "extension", "\"" + extension + "\"",
                "unsupported image format; use .png, .jpg or .exr");
  }
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(ext, encoded_input, bytes, flags)) {
    throw Error::In(destination, "OpenCV could not encode the image as " + ext);
  }
  return bytes;
}

void WriteImage(const std::filesystem::path& path, const Image& image) {
  const std::vector<std::uint8_t> bytes =
      EncodeImage(image, path.extension().string(), path.string());
  WriteFileAtomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()),
                             bytes.size()));
}

cv::Mat ReadMask(const std::filesystem::path& path) {
  const cv::Mat raw = DecodeRaw(ReadFileBytes(path), path.string());
  cv::Mat channel = raw;
  if (raw.channels() > 1) cv::extractChannel(raw, channel, 0);
  cv::Mat out;
  channel.convertTo(out, CV_8U,
                    raw.depth() == CV_16U   ? 1.0 / 257
                    : raw.depth() == CV_32F ? 255.0
                                            : 1.0);
  return out;
}

void WriteMask(const std::filesystem::path& path, const cv::Mat& mask) {
  if (mask.type() != CV_8UC1) {
    throw Error(path.string(), "type", std::to_string(mask.type()),
                "a mask must be CV_8UC1");
  }
  WritePng8(path, mask);
}

void WritePng8(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.depth() != CV_8U ||
      (image.channels() != 1 && image.channels() != 3)) {
    throw Error(path.string(), "type", std::to_string(image.type()),
                "expected an 8-bit grey or BGR image");
  }
  if (path.extension() != ".png") {
    throw Error(path.string(), "extension", path.extension().string(),
                "expected a .png path");
  }
  std::vector<std::uint8_t> bytes;
  if (!cv::imencode(".png", image, bytes)) {
    throw Error::In(path.string(), "PNG encoding failed");
  }
  WriteFileAtomically(
      path, std::string_view(reinterpret_cast<const char*>(bytes.data()),
                             bytes.size()));
}

namespace {

template <typename T>
cv::Mat View(const std::vector<T>& data, int height, int width, int channels) {
  if (data.empty()) return cv::Mat();
  if (height <= 0 || width <= 0 || channels <= 0 ||
      data.size() != static_cast<std::size_t>(height) * width * channels) {
    throw Error("image buffer", "size", std::to_string(data.size()),
                "expected " + std::to_string(height) + " x " +
                    std::to_string(width) + " x " + std::to_string(channels));
  }
  // cv::Mat's vector constructor shares the vector's data.
  return cv::Mat(data, /*copyData=*/false).reshape(channels, height);
}

}  // namespace

cv::Mat MatView(const std::vector<float>& data, int height, int width,
                int channels) {
  return View(data, height, width, channels);
}

cv::Mat MatView(const std::vector<std::uint8_t>& data, int height, int width) {
  return View(data, height, width, 1);
}

}  // namespace pano4d
