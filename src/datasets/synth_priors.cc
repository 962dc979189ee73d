#include "src/datasets/synth_priors.h"

#include <cmath>
#include <random>

#include <opencv2/imgproc.hpp>

#include "src/core/npy.h"
#include "src/datasets/synth_render.h"

namespace pano4d::synth {
namespace fs = std::filesystem;
namespace {

// Coarse grid of the smooth disparity error (columns x rows).
constexpr int kErrorGridColumns = 4, kErrorGridRows = 3;
// The priors' draws, apart from the scene's.
constexpr std::uint32_t kPriorSeedSalt = 0x5eed9;

// The flow from frame `from` (rendered with its surface kept) to the
// camera and poses of `to`: where each pixel's surface point is then.
cv::Mat ExactFlow(const RenderedFrame& from, const PosedCamera& camera,
                  const PartPoses& poses) {
  const int w = from.depth.cols, h = from.depth.rows;
  const Camera& c = camera.camera;
  cv::Mat flow(h, w, CV_32FC2, cv::Scalar(0, 0));
#pragma omp parallel for schedule(static)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      const int part = from.part[i];
      if (part < 0) continue;
      const Eigen::Vector3d world = poses.world_from_part[part] * from.local[i];
      const Eigen::Vector3d p = camera.cam_from_world * world;
      if (!(p.z() > 1e-6)) continue;
      const double u = c.focal_x() * p.x() / p.z() + c.principal_x();
      const double v = c.focal_y() * p.y() / p.z() + c.principal_y();
      flow.at<cv::Vec2f>(y, x) = cv::Vec2f(static_cast<float>(u - (x + 0.5)),
                                           static_cast<float>(v - (y + 0.5)));
    }
  }
  return flow;
}

void WriteMap(const fs::path& path, const cv::Mat& map) {
  const std::vector<float> values(map.ptr<float>(),
                                  map.ptr<float>() + map.total() * map.channels());
  std::vector<std::int64_t> shape = {map.rows, map.cols};
  if (map.channels() > 1) shape.push_back(map.channels());
  WriteNpy(path, NpyArray::FromFloats(shape, values));
}

}  // namespace

nlohmann::json PriorErrorModel::ToJson() const {
  return {{"disparity",
           "a (1/z)(1 + e) + b per frame, blurred: MiDaS-like, DynamicNeRF "
           "disp/"},
          {"disparity_scale", {disparity_scale_min, disparity_scale_max}},
          {"disparity_shift_max", disparity_shift_max},
          {"smooth_error", smooth_error},
          {"edge_blur_pixels", edge_blur_pixels},
          {"flow", "exact, blurred, plus noise: RAFT-like, OmniMotion "
                   "raft_exhaustive/"},
          {"flow_blur_pixels", flow_blur_pixels},
          {"flow_noise_pixels", flow_noise_pixels}};
}

void WriteSynthPriors(const Scene& scene,
                      const std::vector<PriorFrameSource>& frames,
                      std::uint32_t seed, const PriorErrorModel& m,
                      const fs::path& out) {
  std::mt19937 rng(seed ^ kPriorSeedSalt);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    // One frame's surface at a time: its flows need no other render.
    const RenderedFrame rendered = RenderFrame(
        scene, frames[i].camera, frames[i].time, /*shade=*/false,
        /*keep_surface=*/true);
    const cv::Mat& z = rendered.depth;
    cv::Mat inverse;
    cv::divide(1.0, z, inverse, CV_32F);
    inverse.setTo(0, z <= 0);
    const double mean = cv::mean(inverse, z > 0)[0];
    const double a = std::exp(std::log(m.disparity_scale_min) +
                              unit(rng) * std::log(m.disparity_scale_max /
                                                   m.disparity_scale_min));
    const double b = unit(rng) * m.disparity_shift_max * a * mean;
    cv::Mat grid(kErrorGridRows, kErrorGridColumns, CV_32F);
    for (int r = 0; r < kErrorGridRows; ++r)
      for (int c = 0; c < kErrorGridColumns; ++c)
        grid.at<float>(r, c) = static_cast<float>(m.smooth_error * normal(rng));
    cv::Mat error;
    cv::resize(grid, error, z.size(), 0, 0, cv::INTER_CUBIC);
    cv::Mat disparity = inverse.mul(1.0f + error) * a + b;
    if (m.edge_blur_pixels > 0)
      cv::GaussianBlur(disparity, disparity, cv::Size(), m.edge_blur_pixels);
    WriteMap(out / "disp" / (frames[i].id + ".npy"), disparity);

    for (const int j : {static_cast<int>(i) - 1, static_cast<int>(i) + 1}) {
      if (j < 0 || j >= static_cast<int>(frames.size())) continue;
      cv::Mat flow = ExactFlow(rendered, frames[j].camera,
                               PosesAt(scene, frames[j].time));
      if (m.flow_blur_pixels > 0)
        cv::GaussianBlur(flow, flow, cv::Size(), m.flow_blur_pixels);
      for (auto it = flow.begin<cv::Vec2f>(); it != flow.end<cv::Vec2f>(); ++it)
        for (int k = 0; k < 2; ++k)
          (*it)[k] += static_cast<float>(m.flow_noise_pixels * normal(rng));
      WriteMap(out / "raft_exhaustive" /
                   (frames[i].id + ".png_" + frames[j].id + ".png.npy"),
               flow);
    }
  }
}

}  // namespace pano4d::synth
