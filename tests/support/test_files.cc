#include "tests/support/test_files.h"

#include <fstream>
#include <random>

#include "src/core/file.h"
#include "src/core/image.h"

namespace pano4d::testing {

TempDir::TempDir() {
  std::random_device rd;
  path_ = std::filesystem::temp_directory_path() /
          ("pano4d_test_" + std::to_string(rd()) + std::to_string(rd()));
  std::filesystem::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

void WriteTruncatedPng(const std::filesystem::path& path) {
  Image image(32, 24);
  image.mat().setTo(cv::Scalar(0.2, 0.5, 0.8));
  const std::vector<std::uint8_t> bytes =
      EncodeImage(image, ".png", path.string());
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size() / 2));
}

void WriteText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

}  // namespace pano4d::testing
