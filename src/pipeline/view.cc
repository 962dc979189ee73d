#include "src/pipeline/view.h"

#include <cstdlib>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/strings.h"
#include "src/core/workspace_lock.h"
#include "src/gs/scene4d.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// The page's own files, then the libraries it imports (the import map in
// index.html names them) and their licences, from `npm ci`'s node_modules.
struct Copied {
  const char* from;  // under the viewer folder
  const char* to;    // under OUT
};
constexpr Copied kPageFiles[] = {
    {"index.html", "index.html"},
    {"viewer.js", "viewer.js"},
    {"node_modules/three/build/three.module.min.js", "lib/three.module.min.js"},
    {"node_modules/three/build/three.core.min.js", "lib/three.core.min.js"},
    {"node_modules/three/examples/jsm/controls/OrbitControls.js",
     "lib/addons/controls/OrbitControls.js"},
    {"node_modules/three/examples/jsm/postprocessing/Pass.js",
     "lib/addons/postprocessing/Pass.js"},
    {"node_modules/@sparkjsdev/spark/dist/spark.module.min.js",
     "lib/spark.module.min.js"},
    {"node_modules/three/LICENSE", "lib/LICENSE.three.txt"},
    {"node_modules/@sparkjsdev/spark/LICENSE", "lib/LICENSE.spark.txt"},
};

fs::path ViewerSources(const ViewOptions& o) {
  if (!o.viewer.empty()) return o.viewer;
  if (const char* env = std::getenv("PANO4D_VIEWER_DIR"); env && *env)
    return env;
  return PANO4D_VIEWER_DIR;
}

Json TrainingCameras(const FittedWorkspace& fitted) {
  Json cameras = Json::array();
  for (const WorkspaceFrame& f : fitted.frames.train) {
    cameras.push_back(
        {{"name", f.name},
         {"t", f.time},
         {"camera", CameraToJson(RasterCamera::FromPosed(f.camera))}});
  }
  return cameras;
}

}  // namespace

std::uint64_t PlyBytesPerGaussian(int sh_degree) {
  return 4u * (14 + 3 * (sh_degree + 1) * (sh_degree + 1));
}

Json SceneExtras(const FittedWorkspace& fitted) {
  const Eigen::Vector3d centre = fitted.Center();
  Eigen::Vector3d down = Eigen::Vector3d::Zero();
  for (const WorkspaceFrame& f : fitted.frames.train)
    down += RasterCamera::FromPosed(f.camera).rotation.row(1).cast<double>();
  const Eigen::Vector3d up = down.norm() > 0
                                 ? Eigen::Vector3d(-down.normalized())
                                 : Eigen::Vector3d(0, -1, 0);
  const RasterCamera middle =
      RasterCamera::FromPosed(fitted.MiddleFrame().camera);
  const double extent = (middle.Center().cast<double>() - centre).norm();
  Json expanded_json = Json::array();
  for (const ExpandedView& v : fitted.expanded) {
    expanded_json.push_back({{"m", v.m},
                             {"e", v.e},
                             {"t", v.t},
                             {"camera", CameraToJson(v.camera)}});
  }
  return {
      {"centre", {centre.x(), centre.y(), centre.z()}},
      {"up", {up.x(), up.y(), up.z()}},
      {"extent", extent > 0 ? extent : 1.0},
      {"cameras",
       {{"training", TrainingCameras(fitted)}, {"expanded", expanded_json}}}};
}

std::string ViewSummary::FullReport() const {
  std::string s = StringPrintf(
      "pano4d view: %s (open it from a local server: --serve PORT)\n"
      "  scene: %zu static + %zu dynamic Gaussians, %d times, %d motion "
      "bases\n"
      "  scene4d.json + scene4d.bin: %.2f MB (a PLY per time: %.2f MB, "
      "%.1fx); the page and its libraries: %.2f MB\n",
      (out / "index.html").c_str(), static_gaussians, dynamic_gaussians, times,
      bases, scene_bytes / 1e6, ply_sequence_bytes / 1e6,
      scene_bytes > 0 ? double(ply_sequence_bytes) / scene_bytes : 0.0,
      page_bytes / 1e6);
  for (const std::string& n : notes) s += "  note: " + n + "\n";
  return s;
}

ViewSummary RunView(const Workspace& ws, const ViewOptions& o) {
  const fs::path sources = ViewerSources(o);
  for (const Copied& c : kPageFiles) {
    if (!fs::is_regular_file(sources / c.from)) {
      throw Error::In(
          (sources / c.from).string(),
          "missing: the viewer's libraries come from npm; run `bash "
          "scripts/setup.sh` (it runs `npm ci` in src/viewer), or `npm ci "
          "--prefix " +
              sources.string() + "`");
    }
  }
  const FittedWorkspace fitted = LoadFittedWorkspace(ws);
  ViewSummary summary;
  summary.out = o.out.empty() ? ws.pano4d() / "view" : o.out;
  OutputFolder folder(summary.out, ThisCommandLine());
  for (const Copied& c : kPageFiles) {
    const fs::path to = summary.out / c.to;
    WriteAtomically(to, [&](const fs::path& tmp) {
      fs::copy_file(sources / c.from, tmp,
                    fs::copy_options::overwrite_existing);
    });
    summary.page_bytes += fs::file_size(to);
  }
  const GaussianScene& scene = fitted.scene;
  summary.scene_bytes = WriteScene4d(summary.out, scene, SceneExtras(fitted));
  summary.static_gaussians = scene.statics.size();
  summary.dynamic_gaussians = scene.dynamics.size();
  summary.times = scene.num_times;
  summary.bases = scene.bases.num_bases;
  summary.ply_sequence_bytes = PlyBytesPerGaussian(scene.statics.sh_degree) *
                               scene.size() *
                               (scene.has_motion() ? scene.num_times : 1);
  if (scene.statics.sh_degree > 0) {
    summary.notes.push_back(
        "the page draws the SH degree 0 colour; the scene's degree " +
        std::to_string(scene.statics.sh_degree) +
        " view dependence is in scene4d.bin but not shown");
  }
  folder.Complete();
  return summary;
}

}  // namespace pano4d
