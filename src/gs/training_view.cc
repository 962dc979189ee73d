#include "src/gs/training_view.h"

#include <cmath>

#include <opencv2/core.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/npy.h"
#include "src/core/strings.h"

namespace pano4d {

std::vector<TrainingView> LoadTrainingViews(
    const std::vector<WorkspaceFrame>& frames) {
  std::vector<TrainingView> views(frames.size());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const WorkspaceFrame& f = frames[i];
    TrainingView& v = views[i];
    v.name = f.name;
    v.time = f.time;
    v.camera = RasterCamera::FromPosed(f.camera);
    const int w = v.camera.width, h = v.camera.height;
    const Image image = ReadImage(f.rgb);
    if (image.width() != w || image.height() != h) {
      throw Error(f.rgb.string(), "size",
                  SizeText(image.width(), image.height()),
                  "its camera is " + SizeText(w, h));
    }
    const cv::Mat rgb =
        image.mat().isContinuous() ? image.mat() : image.mat().clone();
    v.rgb.assign(rgb.ptr<float>(), rgb.ptr<float>() + w * h * 3);
    if (!f.depth.empty()) {
      const NpyArray depth = ReadNpy(f.depth);
      const bool shape_ok = depth.shape.size() >= 2 && depth.shape[0] == h &&
                            depth.shape[1] == w &&
                            (depth.shape.size() == 2 ||
                             (depth.shape.size() == 3 && depth.shape[2] == 1));
      if (!shape_ok) {
        std::string shape;
        for (auto s : depth.shape) {
          if (!shape.empty()) shape += 'x';
          shape += std::to_string(s);
        }
        throw Error(f.depth.string(), "shape", shape,
                    "expected " + SizeText(h, w) + " like the image");
      }
      v.depth = depth.ToFloats();
      for (float& d : v.depth) {
        if (!std::isfinite(d)) {
          throw Error(f.depth.string(), "value", std::to_string(d),
                      "depth maps must be finite (0 marks no depth)");
        }
        if (d < 0) d = 0;
      }
    }
    if (!f.dynamic_mask.empty()) {
      const cv::Mat mask = ReadMask(f.dynamic_mask);
      if (mask.cols != w || mask.rows != h) {
        throw Error(f.dynamic_mask.string(), "size",
                    SizeText(mask.cols, mask.rows),
                    "its camera is " + SizeText(w, h));
      }
      v.dynamic.resize(static_cast<std::size_t>(w) * h);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          v.dynamic[y * w + x] =
              mask.at<std::uint8_t>(y, x) >= 128 ? kMaskOn : 0;
    }
  }
  return views;
}

}  // namespace pano4d
