#include "src/cli/expansion_outputs.h"

#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "colmap_ext/model.h"
#include "src/core/error.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/progress.h"
#include "src/render/panorama.h"

namespace pano4d::cli {

std::string Padded(int value, int width) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%0*d", width, value);
  return buffer;
}

namespace {

void AddImage(const RasterCamera& c, const std::string& name,
              ColmapModel* model) {
  const auto id = static_cast<std::uint32_t>(model->images.size() + 1);
  ColmapCamera camera;
  camera.camera_id = id;
  camera.model_id = static_cast<int>(CameraModelId::kPinhole);
  camera.width = static_cast<std::uint64_t>(c.width);
  camera.height = static_cast<std::uint64_t>(c.height);
  camera.params = {c.fx, c.fy, c.cx, c.cy};
  model->cameras.push_back(camera);
  ColmapImage image;
  image.image_id = id;
  image.camera_id = id;
  image.name = name;
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(c.rotation.cast<double>()).normalized();
  image.qvec = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  image.tvec = c.translation.cast<double>();
  model->images.push_back(image);
}

}  // namespace

void AddExpansionFlags(CLI::App* sub, ExpansionOptions* o,
                       std::string* warp_depth, std::string* prior_cmd,
                       int* panorama_width) {
  sub->add_option("--directions", o->geometry.directions,
                  "Expansion directions M")
      ->capture_default_str();
  sub->add_option("--expansion-steps", o->geometry.steps, "Expansion steps E")
      ->capture_default_str();
  sub->add_option("--alpha", o->geometry.alpha_degrees,
                  "Angle per expansion step, degrees")
      ->capture_default_str();
  sub->add_option("--expansion-stride", o->time_stride,
                  "Expand every N-th training frame in time")
      ->capture_default_str();
  sub->add_flag("--planar-expansion", o->geometry.planar,
                "Ablation: translate cameras in the image plane instead of "
                "orbiting them on the panorama");
  sub->add_option("--warp-depth", *warp_depth,
                  "The depth the source frames are warped with: given (each "
                  "frame's depth map, rendered depth where it has none) or "
                  "rendered (from the Gaussians, the paper's); default: "
                  "given on depth the dataset gives, rendered on estimated "
                  "depth")
      ->check(CLI::IsMember({"given", "rendered"}));
  sub->add_option("--prior-cmd", *prior_cmd,
                  "External video prior: a command with {in} and {out} "
                  "(folders; see README). Without it, the CPU geometry prior. "
                  "When the command fails, the CPU prior fills in and the log "
                  "says why");
  sub->add_option("--panorama-width", *panorama_width,
                  "Width of the panoramas in WS/pano4d/panorama (height half)")
      ->check(CLI::Range(2, 16384))
      ->capture_default_str();
}

WarpDepth ResolveWarpDepth(const std::string& flag,
                           const std::string& depth_source) {
  if (flag == "given") return WarpDepth::kGiven;
  if (flag == "rendered") return WarpDepth::kRendered;
  if (!flag.empty()) {
    throw Error("--warp-depth", "", flag, "expected given or rendered");
  }
  return depth_source == kDepthFromDataset ? WarpDepth::kGiven
                                           : WarpDepth::kRendered;
}

std::unique_ptr<Prior> MakePrior(const std::string& command,
                                 const std::filesystem::path& work_dir) {
  if (command.empty()) return std::make_unique<GeometryPrior>();
  return std::make_unique<CommandPrior>(command, work_dir,
                                        std::make_unique<GeometryPrior>());
}

void WriteTrajectories(const std::filesystem::path& dir,
                       const std::vector<ExpandedView>& cameras,
                       const std::vector<TrainingView>& sources) {
  Json views = Json::array();
  ColmapModel model;
  for (const TrainingView& v : sources)
    AddImage(v.camera, "source/" + v.name + ".png", &model);
  for (const ExpandedView& v : cameras) {
    views.push_back(ToJson(v));
    AddImage(v.camera,
             "step_" + Padded(v.e, 2) + "/dir_" + std::to_string(v.m) + "/" +
                 (v.name.empty() ? Padded(v.t, 5) : v.name) + ".png",
             &model);
  }
  WriteJson(dir / "trajectories.json",
            {{"note",
              "expanded cameras (DESIGN.md eqs. dir1, dir2): m direction, e "
              "step, t time; qvec (w, x, y, z) and tvec of cam_from_world as "
              "COLMAP"},
             {"views", views}});
  model.BuildIndex();
  WriteModel(model, dir / "colmap", ColmapFormat::kText);
}

void WritePanoramas(const std::filesystem::path& dir,
                    const GaussianScene& scene, const PanoramaFrame& frame,
                    int width, int height) {
  const EquirectProjection projection = frame.Projection(width, height);
  const auto write = [&](const GaussianModel& model,
                         const std::filesystem::path& path) {
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
    write(composed, dir / (Padded(t, 5) + ".png"));
    bar.Add();
  }
  bar.Finish();
}

}  // namespace pano4d::cli
