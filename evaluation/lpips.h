#pragma once

#include <array>
#include <filesystem>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

namespace pano4d {

// LPIPS v0.1 with the AlexNet backbone (richzhang/PerceptualSimilarity,
// `lpips.LPIPS(net="alex", spatial=True)`, as DyCheck evaluates), in plain
// C++ with Eigen. The weights are the user's: a folder of float32 .npy files
//   conv1.weight (64, 3, 11, 11)  conv1.bias (64)  ...  conv5.weight,
//   conv5.bias lin0.weight (1, 64, 1, 1)  ...  lin4.weight (1, 256, 1, 1)
// written from torchvision's AlexNet and LPIPS's alex.pth by
// scripts/lpips_weights_from_torch.py. Channel counts are read from the
// shapes, so a narrower network of the same topology (the test fixture)
// runs through the same code.
class Lpips {
 public:
  // Throws pano4d::Error naming the missing file or the wrong shape.
  static Lpips Load(const std::filesystem::path& weights);

  // The spatial distance map (CV_64FC1, the images' size) between two
  // CV_64FC3 RGB images in [0, 1].
  cv::Mat Map(const cv::Mat& a, const cv::Mat& b) const;

  // DyCheck's value: both images multiplied by the mask, the map averaged
  // over the mask (an empty cv::Mat: every pixel). nullopt for an empty
  // mask.
  std::optional<double> Score(const cv::Mat& a, const cv::Mat& b,
                              const cv::Mat& mask = {}) const;

 private:
  struct Conv {
    int out = 0, in = 0, kernel = 0, stride = 1, pad = 0;
    std::vector<float> weight;  // out x (in * kernel * kernel), row-major
    std::vector<float> bias;
  };
  struct Tensor {
    int channels = 0, height = 0, width = 0;
    std::vector<float> data;  // C x H x W
  };

  std::vector<Tensor> Features(const cv::Mat& image) const;
  static Tensor Convolve(const Tensor& in, const Conv& conv);
  static Tensor MaxPool(const Tensor& in);

  std::array<Conv, 5> convs_;
  std::array<std::vector<float>, 5> lins_;
};

}  // namespace pano4d
