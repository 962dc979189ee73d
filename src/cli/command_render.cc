// pano4d render: novel-view videos of the fitted scene; pano4d export: 3DGS
// PLY per time step and the cameras as a COLMAP model
// (src/pipeline/render.h).
#include <cstdio>
#include <memory>

#include <CLI/CLI.hpp>

#include "src/cli/app.h"
#include "src/cli/options.h"
#include "src/core/workspace_lock.h"
#include "src/pipeline/render.h"

namespace pano4d::cli {
namespace fs = std::filesystem;

void AddRenderCommand(CLI::App& app, Action* action) {
  struct Options {
    fs::path workspace;
    RenderOptions render;
  };
  auto o = std::make_shared<Options>();
  RenderOptions* r = &o->render;
  CLI::App* sub = app.add_subcommand(
      "render",
      "Render novel-view videos of the fitted scene (orbit, spiral, bullet "
      "time, or a camera file)");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (frames.json and the fit checkpoint)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option(
         "--trajectory", r->trajectory,
         "orbit (about the up axis through the scene's centre, time "
         "running), spiral (a circle around the middle input view, time "
         "running), bullet (time frozen, swinging), or a JSON file "
         "{\"views\": [{\"camera\": {width, height, fx, fy, cx, cy, qvec, "
         "tvec}, \"t\": T}]} such as WS/pano4d/expansion/trajectories.json")
      ->capture_default_str();
  sub->add_option("--time", r->time,
                  "The time shown: bullet time (default the middle), or for "
                  "a camera file every view's")
      ->check(NonNegative());
  sub->add_option("--frames", r->frames, "Frames of orbit, spiral, bullet")
      ->check(InRange(1, kMaxRenderFrames))
      ->capture_default_str();
  sub->add_option("--degrees", r->degrees,
                  "The arc (orbit, default 360), circle radius (spiral, 10) "
                  "or swing (bullet, 60)")
      ->check(InRange(0, 720));
  sub->add_option("--fps", r->fps, "Frames per second of the MP4")
      ->check(InRange(1, 240))
      ->capture_default_str();
  sub->add_option("--out", r->out,
                  "Output folder (default WS/pano4d/renders/<trajectory>)");
  sub->footer(
      "Writes OUT/00000.png ..., OUT/<trajectory>.mp4 and OUT/cameras.json "
      "(the cameras in the camera-file layout, to edit and render again).");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock =
          LockWorkspace(o->workspace, FolderLock::Mode::kShared);
      const RenderSummary s = RunRender(Workspace(o->workspace), o->render);
      std::printf("%s", s.FullReport().c_str());
      return kExitOk;
    };
  });
}

void AddExportCommand(CLI::App& app, Action* action) {
  struct Options {
    fs::path workspace;
    ExportOptions export_options;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "export",
      "Export 3DGS PLY per time step and the cameras as a COLMAP model");
  sub->add_option("--workspace", o->workspace,
                  "The workspace (frames.json and the fit checkpoint)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->export_options.out,
                  "Output folder (default WS/pano4d/export)");
  sub->footer(
      "Writes OUT/ply/t_<time>.ply (the 3DGS layout that SuperSplat, "
      "gsplat's viewer and the INRIA viewer open; OUT/ply/static.ply for a "
      "scene without motion), OUT/trajectories.json and OUT/colmap/ "
      "(cameras.txt, images.txt, points3D.txt: the training cameras as "
      "source/<frame>.png beside the expanded ones; COLMAP's GUI: File > "
      "Import model).");
  sub->callback([action, o] {
    *action = [o] {
      const FolderLock lock =
          LockWorkspace(o->workspace, FolderLock::Mode::kShared);
      const ExportSummary s =
          RunExport(Workspace(o->workspace), o->export_options);
      std::printf("%s", s.FullReport().c_str());
      return kExitOk;
    };
  });
}

}  // namespace pano4d::cli
