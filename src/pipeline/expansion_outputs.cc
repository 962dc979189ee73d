#include "src/pipeline/expansion_outputs.h"

#include <algorithm>

#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/log.h"
#include "src/core/progress.h"
#include "src/render/panorama.h"

namespace pano4d {
namespace fs = std::filesystem;

void WritePanoramas(const fs::path& dir, const GaussianScene& scene,
                    const PanoramaFrame& frame, int width, int height) {
  const EquirectProjection projection = frame.Projection(width, height);
  const auto write = [&](const GaussianModel& model, const fs::path& path) {
    const PanoramaImage pano = SplatGaussians(projection, model);
    cv::Mat rgb(pano.height, pano.width, CV_32FC3);
    std::copy(pano.rgb.begin(), pano.rgb.end(), rgb.ptr<float>());
    cv::min(cv::max(rgb, 0.0), 1.0, rgb);
    WriteImage(path, Image::FromRgb32f(rgb));
  };
  write(scene.statics, dir / "static.png");
  ProgressBar bar("panoramas", scene.num_times);
  GaussianModel composed;
  for (int t = 0; t < scene.num_times; ++t) {
    scene.ComposeAt(t, &composed);
    write(composed, dir / (ZeroPadded(t, 5) + ".png"));
    bar.Add();
  }
  bar.Finish();
}

std::vector<SourceCamera> SourceCamerasOf(
    const std::vector<TrainingView>& views) {
  std::vector<SourceCamera> sources;
  for (const TrainingView& v : views) sources.push_back({v.name, v.camera});
  return sources;
}

void WritePanoramaResults(Trainer* trainer, Expansion* expansion,
                          const std::vector<ValidationView>& val,
                          const fs::path& renders) {
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t i = 0; i < val.size(); ++i) {
    const RasterCamera& c = val[i].camera;
    auto same_pose = [&](const std::vector<std::size_t>& g) {
      const RasterCamera& d = val[g.front()].camera;
      return c.rotation == d.rotation && c.translation == d.translation;
    };
    auto g = std::find_if(groups.begin(), groups.end(), same_pose);
    if (g == groups.end()) {
      groups.push_back({i});
    } else {
      g->push_back(i);
    }
  }
  ProgressBar bar("panorama results", static_cast<std::int64_t>(val.size()));
  for (std::vector<std::size_t>& g : groups) {
    std::stable_sort(g.begin(), g.end(), [&](std::size_t a, std::size_t b) {
      return val[a].time < val[b].time;
    });
    std::vector<RasterCamera> cameras;
    std::vector<int> times;
    for (std::size_t i : g) {
      cameras.push_back(val[i].camera);
      times.push_back(val[i].time);
    }
    std::string note;
    const std::vector<cv::Mat> views = expansion->PanoramicViews(
        trainer, "val_" + val[g.front()].name, cameras, times, &note);
    if (!note.empty()) {
      PANO4D_LOG(kWarning) << "panorama results: " << note;
    }
    for (std::size_t k = 0; k < g.size(); ++k) {
      WriteImage(renders / (val[g[k]].name + ".png"),
                 Image::FromRgb32f(views[k].clone()));
    }
    bar.Add(static_cast<std::int64_t>(g.size()));
  }
  bar.Finish();
}

}  // namespace pano4d
