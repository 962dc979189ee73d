#include "src/pano/pairs.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/progress.h"
#include "src/pano/frame.h"
#include "src/pano/trajectory.h"
#include "src/pano/warp.h"

namespace pano4d {
namespace {

constexpr double kDegrees = M_PI / 180.0;
// Every this many pixels of each frame's depth goes into the centroid that
// places the panorama centre: plenty for a mean.
constexpr int kCentroidStride = 8;

cv::Mat AsMat(const TrainingView& v) {
  return MatView(v.rgb, v.camera.height, v.camera.width, 3);
}

cv::Mat DepthMat(const TrainingView& v) {
  return MatView(v.depth, v.camera.height, v.camera.width);
}

}  // namespace

void PairOptions::Check() const {
  if (clips < 1) {
    throw Error("make-pairs options", "clips", std::to_string(clips),
                "must be at least 1");
  }
  if (frames < 2) {
    throw Error("make-pairs options", "frames", std::to_string(frames),
                "must be at least 2");
  }
  if (!(elevation_degrees > 0 && elevation_degrees <= 90)) {
    throw Error("make-pairs options", "elevation",
                std::to_string(elevation_degrees), "must be in (0, 90]");
  }
}

nlohmann::json PairsReport::ToJson() const {
  return {{"clips", clips},
          {"frames_per_clip", frames_per_clip},
          {"mask_fraction", mask_fraction}};
}

namespace {

// The panorama frame of the training views' depth (every kCentroidStride-th
// pixel), as the expansion makes it.
PanoramaFrame FrameOfViews(const std::vector<const TrainingView*>& views) {
  std::vector<Eigen::Vector3f> points;
  std::vector<RasterCamera> cameras;
  for (const TrainingView* v : views) {
    if (v->depth.empty()) {
      throw Error(v->name, "depth", "",
                  "no depth for this frame: run `pano4d depth` first");
    }
    cameras.push_back(v->camera);
    const RasterCamera& c = v->camera;
    for (int y = 0; y < c.height; y += kCentroidStride)
      for (int x = 0; x < c.width; x += kCentroidStride) {
        const float z = v->depth[static_cast<std::size_t>(y) * c.width + x];
        if (!(z > 0)) continue;
        points.push_back(c.Unproject(x + 0.5f, y + 0.5f, z));
      }
  }
  return MakePanoramaFrame(points, cameras);
}

// One frame of a clip: the source warped to the orbit camera and back
// (cov), what the round trip lost (mask) and the source (src); returns its
// meta.json entry and adds the mask's share to `mask_sum`.
nlohmann::json WritePairFrame(const TrainingView& v, const RasterCamera& target,
                              double angle, const std::filesystem::path& clip,
                              int i, double* mask_sum) {
  const WarpResult there = ForwardWarp(AsMat(v), DepthMat(v), v.camera, target);
  const cv::Mat known = there.mask == 0;
  const WarpResult back =
      ForwardWarp(there.rgb, there.depth, target, v.camera, known);
  WriteImage(clip / "cov" / (ZeroPadded(i, 5) + ".png"),
             Image::FromRgb32f(back.rgb.clone()));
  WriteMask(clip / "mask" / (ZeroPadded(i, 5) + ".png"), back.mask);
  WriteImage(clip / "src" / (ZeroPadded(i, 5) + ".png"),
             Image::FromRgb32f(AsMat(v).clone()));
  *mask_sum +=
      static_cast<double>(cv::countNonZero(back.mask)) / back.mask.total();
  return {{"source", v.name},
          {"time", v.time},
          {"angle_degrees", angle / kDegrees},
          {"target_camera", CameraToJson(target)},
          {"source_camera", CameraToJson(v.camera)}};
}

}  // namespace

PairsReport MakeTrainingPairs(const std::vector<TrainingView>& given,
                              const PairOptions& o,
                              const std::filesystem::path& out) {
  o.Check();
  if (given.empty()) {
    throw Error("make-pairs", "views", "0", "no training frames");
  }
  // In time order, stably. An order of pointers, not of the views: GCC 12's
  // std::stable_sort buffer ignores the over-alignment of Eigen members.
  std::vector<const TrainingView*> views;
  for (const TrainingView& v : given) views.push_back(&v);
  std::stable_sort(views.begin(), views.end(),
                   [](const TrainingView* a, const TrainingView* b) {
                     return a->time < b->time;
                   });
  const PanoramaFrame frame = FrameOfViews(views);
  const int count = std::min<int>(o.frames, static_cast<int>(given.size()));
  std::mt19937_64 rng(o.seed);
  PairsReport report;
  report.clips = o.clips;
  report.frames_per_clip = count;
  double mask_sum = 0;
  ProgressBar bar("make-pairs", o.clips * count);
  for (int k = 0; k < o.clips; ++k) {
    const double direction =
        std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
    const int first = std::uniform_int_distribution<int>(
        0, static_cast<int>(given.size()) - count)(rng);
    const RasterCamera& reference = views[first]->camera;
    const Eigen::Vector3d n = ViewingDirection(reference);
    const Eigen::Vector3d right =
        reference.rotation.row(0).transpose().cast<double>();
    const Eigen::Vector3d up =
        -reference.rotation.row(1).transpose().cast<double>();
    const Eigen::Vector3d d =
        std::cos(direction) * right + std::sin(direction) * up;
    const Eigen::Vector3d axis = RotationAxis(n, d);
    const std::filesystem::path clip = out / ("clip_" + ZeroPadded(k, 5));
    nlohmann::json frames = nlohmann::json::array();
    for (int i = 0; i < count; ++i) {
      const TrainingView& v = *views[first + i];
      const double angle = o.elevation_degrees * kDegrees * i / (count - 1);
      frames.push_back(
          WritePairFrame(v, OrbitCamera(v.camera, frame.center, axis, angle),
                         angle, clip, i, &mask_sum));
      bar.Add();
    }
    WriteJson(clip / "meta.json",
              {{"direction_degrees", direction / kDegrees},
               {"elevation_degrees", o.elevation_degrees},
               {"note",
                "cov: the source frame warped to the target camera and "
                "back; mask: 255 where the round trip lost it (what a "
                "prior must fill); src: the source frame"},
               {"frames", frames}});
  }
  bar.Finish();
  report.mask_fraction = mask_sum / (o.clips * count);
  return report;
}

}  // namespace pano4d
