// A stand-in for a video diffusion model behind --prior-cmd, for tests:
//   pano4d_fake_prior MODE IN OUT
// reads IN/frames/*.png and IN/masks/*.png (as CommandPrior writes them) and
// writes OUT/frames/*.png. MODE:
//   fill     masked pixels pure magenta, the others copied
//   fail     a message on stderr, exit status 3
//   small    as fill, at half the size
//   few      as fill, one frame fewer than given
//   garbage  as fill, but 00000.png is not a PNG
// Links only OpenCV core and imgcodecs: it must not share code with what it
// tests.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace fs = std::filesystem;

namespace {

const cv::Vec3b kMagenta(255, 0, 255);  // BGR

cv::Mat Fill(const fs::path& frame_path, const fs::path& mask_path) {
  cv::Mat frame = cv::imread(frame_path.string(), cv::IMREAD_COLOR);
  const cv::Mat mask = cv::imread(mask_path.string(), cv::IMREAD_GRAYSCALE);
  if (frame.empty() || mask.empty() || frame.size() != mask.size()) {
    throw std::runtime_error("cannot read " + frame_path.string() + " or " +
                             mask_path.string());
  }
  for (int y = 0; y < frame.rows; ++y) {
    for (int x = 0; x < frame.cols; ++x) {
      if (mask.at<unsigned char>(y, x) > 127)
        frame.at<cv::Vec3b>(y, x) = kMagenta;
    }
  }
  return frame;
}

// Every other pixel: imgproc's resize is not linked here.
cv::Mat Half(const cv::Mat& frame) {
  cv::Mat half(frame.rows / 2, frame.cols / 2, frame.type());
  for (int y = 0; y < half.rows; ++y) {
    for (int x = 0; x < half.cols; ++x) {
      half.at<cv::Vec3b>(y, x) = frame.at<cv::Vec3b>(2 * y, 2 * x);
    }
  }
  return half;
}

int Run(const std::string& mode, const fs::path& in, const fs::path& out) {
  if (mode == "fail") {
    std::cerr << "fake prior: failing on request" << std::endl;
    return 3;
  }
  if (mode != "fill" && mode != "small" && mode != "few" && mode != "garbage") {
    std::cerr << "fake prior: unknown mode " << mode << std::endl;
    return 2;
  }
  std::vector<fs::path> names;
  for (const auto& entry : fs::directory_iterator(in / "frames")) {
    if (entry.path().extension() == ".png")
      names.push_back(entry.path().filename());
  }
  std::sort(names.begin(), names.end());
  if (mode == "few" && !names.empty()) names.pop_back();
  fs::create_directories(out / "frames");
  for (const fs::path& name : names) {
    cv::Mat frame = Fill(in / "frames" / name, in / "masks" / name);
    if (mode == "small") frame = Half(frame);
    if (!cv::imwrite((out / "frames" / name).string(), frame)) {
      throw std::runtime_error("cannot write " +
                               (out / "frames" / name).string());
    }
  }
  if (mode == "garbage") {
    std::ofstream(out / "frames" / "00000.png") << "this is not a PNG file\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: pano4d_fake_prior fill|fail|small|few|garbage IN OUT"
              << std::endl;
    return 2;
  }
  try {
    return Run(argv[1], argv[2], argv[3]);
  } catch (const std::exception& e) {
    std::cerr << "fake prior: " << e.what() << std::endl;
    return 1;
  }
}
