#include "src/pipeline/render.h"

#include <cstdio>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/memory.h"
#include "src/core/progress.h"
#include "src/core/strings.h"
#include "src/core/workspace_lock.h"
#include "src/gs/scene4d.h"
#include "src/pano/trajectory_io.h"
#include "src/pipeline/scene_outputs.h"
#include "src/pipeline/view.h"
#include "src/render/ply.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The cameras of a named path about the fitted scene's centre.
std::vector<TimedCamera> PathCameras(const FittedWorkspace& fitted,
                                     const RenderOptions& o) {
  const int num_times = fitted.scene.num_times;
  VideoPathOptions v;
  v.path = o.trajectory == "orbit"    ? VideoPath::kOrbit
           : o.trajectory == "spiral" ? VideoPath::kSpiral
                                      : VideoPath::kBullet;
  v.degrees = o.degrees > 0                  ? o.degrees
              : v.path == VideoPath::kOrbit  ? kOrbitDegrees
              : v.path == VideoPath::kSpiral ? kSpiralDegrees
                                             : kBulletDegrees;
  v.frames = o.frames;
  v.num_times = num_times;
  v.time = o.time >= 0 ? o.time : num_times / 2;
  if (v.time >= num_times) {
    throw Error(
        "--time", "", std::to_string(o.time),
        "must be below the scene's " + std::to_string(num_times) + " times");
  }
  return VideoCameras(v, RasterCamera::FromPosed(fitted.MiddleFrame().camera),
                      fitted.Center());
}

// Bytes a rendered pixel takes while its frame is rendered: the
// rasterizer's colour, depth and alpha planes (20), the float and 8-bit
// frames (15), per-pixel bookkeeping, with a margin.
constexpr double kRenderBytesPerPixel = 64;

// Refuses up front (naming the figure) cameras whose frames do not fit in
// the memory available: every frame is kept for the MP4 (3 bytes a pixel),
// and one is rendered at a time.
void CheckRenderMemory(const std::vector<TimedCamera>& cameras) {
  double kept = 0, largest = 0;
  int width = 0, height = 0;
  for (const TimedCamera& c : cameras) {
    const double pixels = static_cast<double>(c.camera.width) * c.camera.height;
    kept += 3 * pixels;
    if (pixels > largest) {
      largest = pixels;
      width = c.camera.width;
      height = c.camera.height;
    }
  }
  CheckMemoryFits(kept + kRenderBytesPerPixel * largest, "render",
                  StringPrintf("%zu frames, the largest %dx%d", cameras.size(),
                               width, height));
}

}  // namespace

std::string RenderSummary::FullReport() const {
  std::string s = StringPrintf(
      "pano4d render: %zu frames of %s in %s%s\n", frames, name.c_str(),
      out.c_str(), video.empty() ? "" : (", video " + video.string()).c_str());
  for (const std::string& n : notes) s += "  not written: " + n + "\n";
  return s;
}

RenderSummary RunRender(const Workspace& ws, const RenderOptions& o) {
  const FittedWorkspace fitted = LoadFittedWorkspace(ws);
  const int num_times = fitted.scene.num_times;
  std::vector<TimedCamera> cameras;
  // Each camera as cameras.json will hold it; the cameras render from
  // these, so that the file renders the same frames again.
  std::vector<nlohmann::json> cameras_json;
  RenderSummary summary;
  summary.name = o.trajectory;
  if (o.trajectory == "orbit" || o.trajectory == "spiral" ||
      o.trajectory == "bullet") {
    cameras = PathCameras(fitted, o);
    for (TimedCamera& c : cameras) {
      cameras_json.push_back(CameraToJson(c.camera));
      c.camera = RasterCameraFromJson(cameras_json.back(), "render");
    }
  } else {
    if (!fs::exists(o.trajectory)) {
      throw Error("--trajectory", "", o.trajectory,
                  "is neither orbit, spiral, bullet nor an existing camera "
                  "file ({\"views\": [{\"camera\": {...}, \"t\": T}]})");
    }
    cameras = ReadCameraFile(o.trajectory, &cameras_json);
    summary.name = fs::path(o.trajectory).stem().string();
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      if (o.time >= 0) cameras[i].time = o.time;
      if (cameras[i].time < 0 || cameras[i].time >= num_times) {
        throw Error(o.trajectory + " view " + std::to_string(i), "t",
                    std::to_string(cameras[i].time),
                    "must be in [0, " + std::to_string(num_times) + ")");
      }
    }
  }
  CheckRenderMemory(cameras);
  summary.out = o.out.empty() ? ws.renders(summary.name) : o.out;
  OutputFolder folder(summary.out, ThisCommandLine(), R"([0-9]{5}\.png)");
  SceneRenderer renderer(fitted.scene);
  ProgressBar bar("render " + summary.name,
                  static_cast<std::int64_t>(cameras.size()));
  std::vector<cv::Mat> frames;
  nlohmann::json views = nlohmann::json::array();
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    frames.push_back(renderer.Render(cameras[i].camera, cameras[i].time));
    WriteImage(summary.out / (ZeroPadded(static_cast<int>(i), 5) + ".png"),
               Image::FromOpenCV(frames.back(), summary.name));
    views.push_back({{"camera", cameras_json[i]}, {"t", cameras[i].time}});
    bar.Add();
  }
  bar.Finish();
  // The cameras in the camera-file layout, so that the path can be edited
  // and rendered again with --trajectory FILE.
  WriteJson(summary.out / "cameras.json", {{"views", views}});
  const fs::path video = summary.out / (summary.name + ".mp4");
  if (WriteVideo(video, frames, o.fps, &summary.notes)) summary.video = video;
  summary.frames = frames.size();
  folder.Complete();
  return summary;
}

std::string ExportSummary::FullReport() const {
  return StringPrintf(
      "pano4d export: %d PLY file(s) (%zu Gaussians each%s) in %s, %.2f MB, "
      "listed in %s\n"
      "  compact 4D scene: %s + %s, %.2f MB (%.1fx smaller)\n"
      "  cameras: %zu training and %zu expanded, as a COLMAP model in %s\n",
      ply_files, gaussians, motion ? ", one file per time step" : ", no motion",
      (out / "ply").c_str(), ply_bytes / 1e6, manifest.filename().c_str(),
      (out / kScene4dJson).c_str(), kScene4dBinary, scene4d_bytes / 1e6,
      scene4d_bytes > 0 ? double(ply_bytes) / scene4d_bytes : 0.0,
      training_cameras, expanded_cameras, (out / "colmap").c_str());
}

ExportSummary RunExport(const Workspace& ws, const ExportOptions& o) {
  const FittedWorkspace fitted = LoadFittedWorkspace(ws);
  ExportSummary summary;
  summary.out = o.out.empty() ? ws.export_dir() : o.out;
  OutputFolder folder(summary.out, ThisCommandLine(),
                      R"(ply/(t_[0-9]+|static)\.ply)");
  const fs::path ply = summary.out / "ply";
  EnsureDirectory(ply);
  const GaussianScene& scene = fitted.scene;
  GaussianModel posed;
  summary.motion = scene.has_motion();
  // The manifest of the sequence: one PLY per time, the same Gaussians in
  // the same order in each (static rows first), so that a player can
  // step through the files by name or by this list.
  Json files = Json::array();
  if (summary.motion) {
    ProgressBar bar("export ply", scene.num_times);
    for (int t = 0; t < scene.num_times; ++t) {
      scene.ComposeAt(t, &posed);
      const std::string name = "t_" + ZeroPadded(t, 5) + ".ply";
      WritePly(ply / name, posed);
      files.push_back({{"file", name}, {"time", t}});
      ++summary.ply_files;
      bar.Add();
    }
    bar.Finish();
  } else {
    // No motion: one scene holds for every time.
    scene.ComposeAt(0, &posed);
    WritePly(ply / "static.ply", posed);
    files.push_back({{"file", "static.ply"}, {"time", 0}});
    summary.ply_files = 1;
  }
  summary.gaussians = posed.size();
  WriteJson(ply / kPlySequenceManifest,
            {{"format", "pano4d-ply-sequence"},
             {"version", 1},
             {"num_times", scene.num_times},
             {"fps", kExportFps},
             {"gaussians", posed.size()},
             {"static_gaussians", scene.statics.size()},
             {"sh_degree", posed.sh_degree},
             {"same_order", true},
             {"frames", files}});
  summary.manifest = ply / kPlySequenceManifest;
  std::vector<SourceCamera> sources;
  for (const WorkspaceFrame& f : fitted.frames.train)
    sources.push_back({f.name, RasterCamera::FromPosed(f.camera)});
  WriteTrajectories(summary.out, fitted.expanded, sources);
  summary.training_cameras = sources.size();
  summary.expanded_cameras = fitted.expanded.size();
  // The compact 4D form, which `pano4d view`'s page loads.
  summary.scene4d_bytes = WriteScene4d(summary.out, scene, SceneExtras(fitted));
  for (const Json& f : files)
    summary.ply_bytes += fs::file_size(ply / f["file"].get<std::string>());
  folder.Complete();
  return summary;
}

}  // namespace pano4d
