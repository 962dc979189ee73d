#include "evaluation/lpips.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "src/core/error.h"
#include "src/core/npy.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

// LPIPS's ScalingLayer: (x - shift) / scale, on inputs in [-1, 1].
constexpr std::array<float, 3> kShift = {-0.030f, -0.088f, -0.188f};
constexpr std::array<float, 3> kScale = {0.458f, 0.448f, 0.450f};
// lpips.normalize_tensor's guard against dividing by a zero feature norm.
constexpr float kNormalizeEps = 1e-10f;
// DyCheck's masked_mean.
constexpr double kMaskedMeanEps = 1e-6;

// AlexNet's features as torchvision builds them: kernel, stride, padding;
// a 3x3 / 2 max pool runs before conv2 and conv3.
struct Layer {
  int kernel, stride, pad;
};
constexpr std::array<Layer, 5> kLayers = {
    {{11, 4, 2}, {5, 1, 2}, {3, 1, 1}, {3, 1, 1}, {3, 1, 1}}};

using RowMatrix =
    Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

NpyArray LoadArray(const std::filesystem::path& dir, const std::string& name,
                   const std::vector<std::int64_t>& shape_pattern) {
  const std::filesystem::path path = dir / (name + ".npy");
  if (!std::filesystem::exists(path)) {
    throw Error::In(path.string(),
                    "LPIPS weight file is missing; make the folder with "
                    "scripts/lpips_weights_from_torch.py");
  }
  NpyArray array = ReadNpy(path);
  bool ok = array.kind == 'f' && array.shape.size() == shape_pattern.size();
  for (std::size_t i = 0; ok && i < shape_pattern.size(); ++i) {
    ok = shape_pattern[i] < 0 || array.shape[i] == shape_pattern[i];
  }
  if (!ok) {
    std::string shape;
    for (const auto d : array.shape) {
      if (!shape.empty()) shape += "x";
      shape += std::to_string(d);
    }
    throw Error(path.string(), "shape", shape + " " + array.descr(),
                "unexpected for " + name);
  }
  for (const float v : array.ToFloats()) {
    if (!std::isfinite(v)) {
      throw Error(path.string(), "values", std::to_string(v),
                  "LPIPS weights must be finite (a damaged conversion?); "
                  "make the folder again with "
                  "scripts/lpips_weights_from_torch.py");
    }
  }
  return array;
}

}  // namespace

Lpips Lpips::Load(const std::filesystem::path& weights) {
  if (!std::filesystem::is_directory(weights)) {
    throw Error::In(weights.string(),
                    "is not a folder of LPIPS weights (.npy); make one with "
                    "scripts/lpips_weights_from_torch.py from torchvision's "
                    "AlexNet and LPIPS's "
                    "alex.pth");
  }
  Lpips lpips;
  int in_channels = 3;
  for (int l = 0; l < 5; ++l) {
    const std::string name = "conv" + std::to_string(l + 1);
    const int k = kLayers[l].kernel;
    const NpyArray w =
        LoadArray(weights, name + ".weight", {-1, in_channels, k, k});
    const int out = static_cast<int>(w.shape[0]);
    const NpyArray b = LoadArray(weights, name + ".bias", {out});
    Conv& conv = lpips.convs_[l];
    conv.out = out;
    conv.in = in_channels;
    conv.kernel = k;
    conv.stride = kLayers[l].stride;
    conv.pad = kLayers[l].pad;
    conv.weight = w.ToFloats();
    conv.bias = b.ToFloats();
    lpips.lins_[l] = LoadArray(weights, "lin" + std::to_string(l) + ".weight",
                               {1, out, 1, 1})
                         .ToFloats();
    in_channels = out;
  }
  return lpips;
}

Lpips::Tensor Lpips::Convolve(const Tensor& in, const Conv& conv) {
  const int k = conv.kernel;
  const int height = (in.height + 2 * conv.pad - k) / conv.stride + 1;
  const int width = (in.width + 2 * conv.pad - k) / conv.stride + 1;
  // im2col: one column per output pixel, rows in (channel, ky, kx) order,
  // matching the (out, in, k, k) weight layout.
  RowMatrix columns(static_cast<Eigen::Index>(conv.in) * k * k,
                    static_cast<Eigen::Index>(height) * width);
  for (int c = 0; c < conv.in; ++c) {
    for (int ky = 0; ky < k; ++ky) {
      for (int kx = 0; kx < k; ++kx) {
        float* row =
            columns.row((static_cast<Eigen::Index>(c) * k + ky) * k + kx)
                .data();
        for (int y = 0; y < height; ++y) {
          const int sy = y * conv.stride - conv.pad + ky;
          for (int x = 0; x < width; ++x) {
            const int sx = x * conv.stride - conv.pad + kx;
            row[y * width + x] =
                (sy < 0 || sy >= in.height || sx < 0 || sx >= in.width)
                    ? 0.0f
                    : in.data[(static_cast<std::size_t>(c) * in.height + sy) *
                                  in.width +
                              sx];
          }
        }
      }
    }
  }
  const Eigen::Map<const RowMatrix> weight(
      conv.weight.data(), conv.out, static_cast<Eigen::Index>(conv.in) * k * k);
  RowMatrix result = weight * columns;
  Tensor out{conv.out, height, width, {}};
  out.data.resize(static_cast<std::size_t>(conv.out) * height * width);
  for (int o = 0; o < conv.out; ++o) {
    for (Eigen::Index i = 0; i < result.cols(); ++i) {
      out.data[o * result.cols() + i] =
          std::max(0.0f, result(o, i) + conv.bias[o]);  // ReLU
    }
  }
  return out;
}

Lpips::Tensor Lpips::MaxPool(const Tensor& in) {
  // 3x3, stride 2, no padding, floor: torch.nn.MaxPool2d(3, 2).
  Tensor out{in.channels, (in.height - 3) / 2 + 1, (in.width - 3) / 2 + 1, {}};
  out.data.resize(static_cast<std::size_t>(out.channels) * out.height *
                  out.width);
  for (int c = 0; c < in.channels; ++c) {
    for (int y = 0; y < out.height; ++y) {
      for (int x = 0; x < out.width; ++x) {
        float best = -std::numeric_limits<float>::infinity();
        for (int dy = 0; dy < 3; ++dy) {
          for (int dx = 0; dx < 3; ++dx) {
            best = std::max(
                best,
                in.data[(static_cast<std::size_t>(c) * in.height + 2 * y + dy) *
                            in.width +
                        2 * x + dx]);
          }
        }
        out.data[(static_cast<std::size_t>(c) * out.height + y) * out.width +
                 x] = best;
      }
    }
  }
  return out;
}

std::vector<Lpips::Tensor> Lpips::Features(const cv::Mat& image) const {
  // [0, 1] -> [-1, 1] (im2tensor with factor 1/2) -> ScalingLayer.
  Tensor x{3, image.rows, image.cols, {}};
  x.data.resize(static_cast<std::size_t>(3) * image.rows * image.cols);
  for (int y = 0; y < image.rows; ++y) {
    for (int c = 0; c < 3; ++c) {
      for (int xx = 0; xx < image.cols; ++xx) {
        const float v =
            static_cast<float>(image.at<cv::Vec3d>(y, xx)[c]) * 2.0f - 1.0f;
        x.data[(static_cast<std::size_t>(c) * image.rows + y) * image.cols +
               xx] = (v - kShift[c]) / kScale[c];
      }
    }
  }
  std::vector<Tensor> features;
  features.push_back(Convolve(x, convs_[0]));
  features.push_back(Convolve(MaxPool(features.back()), convs_[1]));
  features.push_back(Convolve(MaxPool(features.back()), convs_[2]));
  features.push_back(Convolve(features.back(), convs_[3]));
  features.push_back(Convolve(features.back(), convs_[4]));
  return features;
}

cv::Mat Lpips::Map(const cv::Mat& a, const cv::Mat& b) const {
  if (a.type() != CV_64FC3 || b.type() != CV_64FC3 || a.size() != b.size()) {
    throw Error("lpips", "images", "",
                "expects two CV_64FC3 images of the same size");
  }
  // conv1 (11x11 / 4) then two 3x3 / 2 pools must leave at least one pixel.
  if (a.rows < 35 || a.cols < 35) {
    throw Error("lpips", "size", SizeText(a.cols, a.rows),
                "LPIPS needs images of at least 35x35");
  }
  const std::vector<Tensor> fa = Features(a), fb = Features(b);
  cv::Mat map(a.rows, a.cols, CV_64FC1, cv::Scalar(0.0));
  for (int l = 0; l < 5; ++l) {
    const Tensor& ta = fa[l];
    const Tensor& tb = fb[l];
    const std::size_t plane = static_cast<std::size_t>(ta.height) * ta.width;
    // Per location: unit-normalise each feature vector, squared difference,
    // then the learned 1x1 linear layer.
    std::vector<float> layer(plane, 0.0f);
    for (std::size_t p = 0; p < plane; ++p) {
      float na = 0, nb = 0;
      for (int c = 0; c < ta.channels; ++c) {
        na += ta.data[c * plane + p] * ta.data[c * plane + p];
        nb += tb.data[c * plane + p] * tb.data[c * plane + p];
      }
      na = std::sqrt(na) + kNormalizeEps;
      nb = std::sqrt(nb) + kNormalizeEps;
      float sum = 0;
      for (int c = 0; c < ta.channels; ++c) {
        const float d =
            ta.data[c * plane + p] / na - tb.data[c * plane + p] / nb;
        sum += lins_[l][c] * d * d;
      }
      layer[p] = sum;
    }
    // Bilinear upsampling to the input size, align_corners=False (PyTorch's
    // source index: (dst + 0.5) * in / out - 0.5, clamped at 0).
    const double sy = static_cast<double>(ta.height) / a.rows;
    const double sx = static_cast<double>(ta.width) / a.cols;
    for (int y = 0; y < a.rows; ++y) {
      const double fy = std::max(0.0, (y + 0.5) * sy - 0.5);
      const int y0 = std::min(static_cast<int>(fy), ta.height - 1);
      const int y1 = std::min(y0 + 1, ta.height - 1);
      const double wy = fy - y0;
      for (int x = 0; x < a.cols; ++x) {
        const double fx = std::max(0.0, (x + 0.5) * sx - 0.5);
        const int x0 = std::min(static_cast<int>(fx), ta.width - 1);
        const int x1 = std::min(x0 + 1, ta.width - 1);
        const double wx = fx - x0;
        const double top = (1 - wx) * layer[y0 * ta.width + x0] +
                           wx * layer[y0 * ta.width + x1];
        const double bottom = (1 - wx) * layer[y1 * ta.width + x0] +
                              wx * layer[y1 * ta.width + x1];
        map.at<double>(y, x) += (1 - wy) * top + wy * bottom;
      }
    }
  }
  return map;
}

std::optional<double> Lpips::Score(const cv::Mat& a, const cv::Mat& b,
                                   const cv::Mat& mask) const {
  double value = 0;
  if (mask.empty()) {
    value = cv::mean(Map(a, b))[0];
  } else {
    const double weight = cv::sum(mask)[0];
    if (weight == 0) return std::nullopt;
    cv::Mat mask3, masked_a, masked_b;
    cv::merge(std::vector<cv::Mat>{mask, mask, mask}, mask3);
    cv::multiply(a, mask3, masked_a);
    cv::multiply(b, mask3, masked_b);
    const cv::Mat map = Map(masked_a, masked_b);
    value = cv::sum(map.mul(mask))[0] / std::max(weight, kMaskedMeanEps);
  }
  // A number in a report must be one: non-finite input pixels or a network
  // that overflows end here, not as -inf in a CSV.
  if (!std::isfinite(value)) {
    throw Error("lpips", "score", std::to_string(value),
                "not finite (are the images finite?)");
  }
  return value;
}

}  // namespace pano4d
