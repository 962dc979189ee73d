#include "src/pipeline/report.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/strings.h"
#include "src/pano/trajectory_io.h"
#include "src/pipeline/scene_outputs.h"
#include "src/render/ply.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Frames per validation camera in the contact sheet.
constexpr int kSheetFrames = 4;
// Expanded steps per direction in the contact sheet (spread over 1..E).
constexpr int kSheetSteps = 6;
constexpr double kVideoFps = 10.0;
// |render - ground truth| is multiplied by this so that errors of a few
// grey levels show.
constexpr double kErrorGain = 4.0;

cv::Mat Bgr8(const fs::path& path) { return ReadImage(path).ToBgr8(); }

cv::Mat Labelled(cv::Mat image, const std::string& label) {
  image = image.clone();
  cv::putText(image, label, {4, 14}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return image;
}

// Rows of equal width: shorter rows are padded with black.
cv::Mat Stack(const std::vector<std::vector<cv::Mat>>& rows) {
  std::vector<cv::Mat> joined;
  int width = 0;
  for (const auto& row : rows) {
    cv::Mat r;
    cv::hconcat(row, r);
    width = std::max(width, r.cols);
    joined.push_back(r);
  }
  for (cv::Mat& r : joined) {
    if (r.cols < width)
      cv::copyMakeBorder(r, r, 0, 0, 0, width - r.cols, cv::BORDER_CONSTANT);
  }
  cv::Mat out;
  cv::vconcat(joined, out);
  return out;
}

struct Writer {
  fs::path dir;
  ReportSummary* summary;
  void Image(const std::string& name, const cv::Mat& bgr) {
    WriteImage(dir / name, pano4d::Image::FromOpenCV(bgr, name));
    summary->files.push_back(name);
  }
  void Video(const std::string& name, const std::vector<cv::Mat>& frames) {
    if (WriteVideo(dir / name, frames, kVideoFps, &summary->notes))
      summary->files.push_back(name);
  }
  void Copy(const fs::path& from, const std::string& name) {
    if (!fs::exists(from)) {
      summary->notes.push_back(name + ": " + from.string() + " is missing");
      return;
    }
    WriteAtomically(dir / name, [&](const fs::path& tmp) {
      fs::copy_file(from, tmp, fs::copy_options::overwrite_existing);
    });
    summary->files.push_back(name);
  }
};

// The camera a frame name starts with ("1_00040" -> "1").
std::string CameraOf(const std::string& name) {
  return name.substr(0, name.find('_'));
}

// Validation frames: ground truth | render | error on covisible pixels
// (unseen pixels grey), a few frames per camera; and a video of the first
// camera's frames side by side.
void ValidationViews(const Workspace& ws, const WorkspaceFrames& frames,
                     Writer* out) {
  std::map<std::string, std::vector<const WorkspaceFrame*>> by_camera;
  for (const WorkspaceFrame& f : frames.val)
    by_camera[CameraOf(f.name)].push_back(&f);
  const fs::path renders = ws.val_renders();
  const auto row = [&](const WorkspaceFrame& f) {
    const cv::Mat gt = Bgr8(f.rgb);
    const cv::Mat render = Bgr8(renders / (f.name + ".png"));
    if (render.size() != gt.size()) {
      throw Error((renders / (f.name + ".png")).string(), "size", "",
                  "differs from its ground truth " + f.rgb.string());
    }
    cv::Mat error;
    cv::absdiff(render, gt, error);
    error.convertTo(error, CV_8UC3, kErrorGain);
    if (!f.covisible.empty() && fs::exists(f.covisible)) {
      const cv::Mat seen = ReadMask(f.covisible) >= 128;
      error.setTo(cv::Scalar(64, 64, 64), ~seen);
    }
    return std::vector<cv::Mat>{Labelled(gt, f.name + " ground truth"),
                                Labelled(render, "render"),
                                Labelled(error, "error x4 (grey: unseen)")};
  };
  std::vector<std::vector<cv::Mat>> rows;
  for (auto& [camera, list] : by_camera) {
    std::sort(list.begin(), list.end(),
              [](auto* a, auto* b) { return a->time < b->time; });
    const int n = std::min<int>(kSheetFrames, static_cast<int>(list.size()));
    for (int i = 0; i < n; ++i)
      rows.push_back(row(*list[i * (list.size() - 1) / std::max(1, n - 1)]));
  }
  if (rows.empty()) {
    out->summary->notes.push_back(
        "val_sheet.png: the dataset has no validation frames");
    return;
  }
  out->Image("val_sheet.png", Stack(rows));
  std::vector<cv::Mat> video;
  for (const WorkspaceFrame* f : by_camera.begin()->second) {
    cv::Mat both;
    cv::hconcat(Bgr8(f->rgb), Bgr8(renders / (f->name + ".png")), both);
    video.push_back(both);
  }
  out->Video("val.mp4", video);
}

// The Gaussians rendered at the expanded cameras of the source frame in the
// middle of the video: a row per direction (the source view, then steps
// 1..E), and a video that swings from one direction's last step through the
// source view to the other's.
void ExpandedViews(const Workspace& ws, const FittedWorkspace& fitted,
                   Writer* out) {
  const fs::path path = ws.trajectories_json();
  if (!fs::exists(path)) {
    out->summary->notes.push_back(
        "expanded views: no expansion ran (see plan.json)");
    return;
  }
  const std::vector<ExpandedView> views = ReadTrajectories(path);
  std::vector<std::string> sources;
  for (const ExpandedView& v : views) sources.push_back(v.name);
  std::sort(sources.begin(), sources.end());
  sources.erase(std::unique(sources.begin(), sources.end()), sources.end());
  if (sources.empty()) return;
  const std::string source = sources[sources.size() / 2];
  const WorkspaceFrame* frame = nullptr;
  for (const WorkspaceFrame& f : fitted.frames.train)
    if (f.name == source) frame = &f;
  if (!frame) {
    throw Error(path.string(), "source", source,
                "is not a training frame of frames.json");
  }
  SceneRenderer renderer(fitted.scene);
  const cv::Mat source_view =
      renderer.Render(RasterCamera::FromPosed(frame->camera), frame->time);
  // [m][e]: the render at direction m, step e.
  std::map<int, std::map<int, cv::Mat>> at;
  for (const ExpandedView& v : views)
    if (v.name == source) at[v.m][v.e] = renderer.Render(v.camera, v.t);
  std::vector<std::vector<cv::Mat>> rows;
  for (auto& [m, steps] : at) {
    std::vector<cv::Mat> row{Labelled(source_view, source + " (source)")};
    const int last = steps.rbegin()->first;
    const int n = std::min(kSheetSteps, last);
    for (int i = 1; i <= n; ++i) {
      const int e = (i * last + n - 1) / n;  // spread over 1..last
      if (steps.count(e)) {
        row.push_back(Labelled(steps[e], "direction " + std::to_string(m) +
                                             ", step " + std::to_string(e)));
      }
    }
    rows.push_back(row);
  }
  out->Image("expanded_sheet.png", Stack(rows));
  std::vector<cv::Mat> swing;
  if (at.size() >= 2) {
    auto second = std::next(at.begin());
    for (auto e = second->second.rbegin(); e != second->second.rend(); ++e)
      swing.push_back(e->second);
  }
  swing.push_back(source_view);
  for (auto& [e, image] : at.begin()->second) swing.push_back(image);
  out->Video("expanded.mp4", swing);
}

std::string PlanTable(const nlohmann::json& plan) {
  std::ostringstream s;
  s << "| stage | decision | why | status | seconds |\n|---|---|---|---|---|\n";
  const nlohmann::json results =
      plan.value("results", nlohmann::json::object());
  for (const auto& stage : plan.at("stages")) {
    const std::string name = stage.at("stage");
    // Motion and expansion are parts of the fit.
    std::string status = stage.value("run", false) ? "in fit" : "-";
    std::string seconds = "-";
    if (results.contains(name)) {
      status = results[name].value("status", "");
      char b[32];
      std::snprintf(b, sizeof(b), "%.1f", results[name].value("seconds", 0.0));
      seconds = b;
    }
    s << "| " << name << " | "
      << (stage.value("run", false) ? "run" : "left out") << " | "
      << stage.value("why", "") << " | " << status << " | " << seconds
      << " |\n";
  }
  return s.str();
}

// The scene at its canonical time as a PLY, and the panoramas (the static
// one and the middle time's).
void SceneFiles(const Workspace& ws, const GaussianScene& scene, Writer* out,
                ReportSummary* summary) {
  GaussianModel model;
  scene.ComposeAt(scene.canonical_time, &model);
  const std::string ply =
      "scene_t" + std::to_string(scene.canonical_time) + ".ply";
  WritePly(summary->dir / ply, model);
  summary->files.push_back(ply);
  const fs::path panoramas = ws.panorama();
  if (fs::exists(panoramas / "static.png"))
    out->Copy(panoramas / "static.png", "panorama_static.png");
  std::vector<fs::path> per_time;
  if (fs::is_directory(panoramas)) {
    for (const auto& e : fs::directory_iterator(panoramas))
      if (e.path().filename() != "static.png") per_time.push_back(e.path());
  }
  std::sort(per_time.begin(), per_time.end());
  if (!per_time.empty())
    out->Copy(per_time[per_time.size() / 2], "panorama_middle.png");
}

// index.md's opening: the input, the fit's size and the share COLMAP posed.
std::string InputSection(const Workspace& ws, const nlohmann::json& plan,
                         const nlohmann::json& fit,
                         const WorkspaceFrames& frames) {
  std::ostringstream md;
  md << "Input: " << plan.at("input").value("kind", "") << " `"
     << plan.at("input").value("path", "") << "`; " << frames.train.size()
     << " training and " << frames.val.size() << " validation frames; "
     << fit.value("iterations", 0) << " fit iterations, "
     << fit.value("static_gaussians", 0) << " static and "
     << fit.value("dynamic_gaussians", 0) << " dynamic Gaussians.\n\n";
  const nlohmann::json facts = plan.value("facts", nlohmann::json::object());
  if (facts.value("sfm_frames", nlohmann::json()).is_number()) {
    const int given = facts["sfm_frames"].get<int>();
    const int posed = facts.value("sfm_posed", 0);
    md << "COLMAP posed " << posed << " of " << given << " frames ("
       << StringPrintf("%.1f%%", 100.0 * posed / std::max(1, given)) << ")";
    if (posed < given) {
      md << "; the " << given - posed
         << " unposed frames are not in the fit (why: "
         << ws.sfm_json().string() << ", key diagnosis)";
    }
    md << ".\n\n";
  }
  return md.str();
}

// The metrics table, with how to reproduce it.
std::string MetricsSection(const Workspace& ws, const WorkspaceFrames& frames,
                           const fs::path& dir) {
  std::ostringstream md;
  md << "## Metrics (beside the published rows)\n\n";
  if (!frames.dataset.empty()) {
    md << "Reproduce with `pano4d eval --dataset " << frames.dataset.string()
       << " --factor " << frames.dataset_factor << " --renders "
       << ws.val_renders().string() << "`. ";
  }
  if (fs::exists(frames.dataset / "synth.json")) {
    md << "This scene is synthetic and the published means are over "
          "DyCheck's real iPhone captures: compare the pattern across the "
          "columns (full, covisible m*, unseen u*), not the values.";
  }
  md << "\n\n";
  std::string table = ReadTextFile(dir / "metrics.md");
  if (table.rfind("# ", 0) == 0) table = table.substr(table.find('\n') + 1);
  md << table << "\n";
  return md.str();
}

}  // namespace

ReportSummary WriteReport(const Workspace& ws) {
  ReportSummary summary;
  summary.dir = ws.report();
  EnsureDirectory(summary.dir);
  Writer out{summary.dir, &summary};
  const fs::path plan_path = ws.plan_json();
  const fs::path fit_path = ws.fit_json();
  for (const fs::path& needed : {plan_path, fit_path}) {
    if (!fs::exists(needed)) {
      throw Error(needed.string(), "", "",
                  "missing; the report reads what `pano4d run` wrote");
    }
  }
  const nlohmann::json plan = ReadJson(plan_path);
  const nlohmann::json fit = ReadJson(fit_path);
  const FittedWorkspace fitted = LoadFittedWorkspace(ws);
  const WorkspaceFrames& frames = fitted.frames;

  out.Copy(plan_path, "plan.json");
  out.Copy(ws.fit_plot(), "fit.png");
  out.Copy(ws.fit_csv(), "fit.csv");
  const bool evaluated = fs::exists(ws.metrics() / "metrics.md");
  if (evaluated) {
    out.Copy(ws.metrics() / "metrics.md", "metrics.md");
    out.Copy(ws.metrics_json(), "metrics.json");
    out.Copy(ws.metrics() / "per_frame.csv", "per_frame.csv");
  }
  ValidationViews(ws, frames, &out);
  ExpandedViews(ws, fitted, &out);
  SceneFiles(ws, fitted.scene, &out, &summary);

  std::ostringstream md;
  md << "# pano4d report\n\n" << InputSection(ws, plan, fit, frames);
  md << "## Stages\n\n" << PlanTable(plan) << "\n";
  if (evaluated) md << MetricsSection(ws, frames, summary.dir);
  md << "## Error against run time\n\n![fit](fit.png)\n\n"
     << "The fit ran " << fit.value("iterations", 0) << " iterations ("
     << fit.value("termination", std::string("?")) << ")";
  const nlohmann::json convergence = fit.value("convergence", nlohmann::json());
  if (fit.value("termination", std::string()) == "converged" &&
      convergence.is_object()) {
    md << ": the convergence stop on the "
       << convergence.value("signal", std::string("?")) << " PSNR, "
       << convergence.value("reason", std::string());
  }
  md << ".\n\n";
  md << "## Validation views\n\nGround truth, render, and the error x"
     << kErrorGain
     << " on the covisible pixels (unseen pixels grey). Video: "
        "[val.mp4](val.mp4).\n\n![validation](val_sheet.png)\n\n";
  md << "## Expanded views\n\nThe Gaussians at the panoramic expansion's "
        "cameras (one row per direction, steps outwards). Video: "
        "[expanded.mp4](expanded.mp4).\n\n![expanded](expanded_sheet.png)"
        "\n\n";
  md << "## Panoramas\n\n![static](panorama_static.png)\n\n"
        "![one time step](panorama_middle.png)\n\n";
  md << "## Files\n\n";
  for (const std::string& f : summary.files)
    md << "- [" << f << "](" << f << ")\n";
  if (!summary.notes.empty()) {
    md << "\n## Not written\n\n";
    for (const std::string& n : summary.notes) md << "- " << n << "\n";
  }
  WriteFileAtomically(summary.dir / "index.md", md.str());
  summary.files.insert(summary.files.begin(), "index.md");
  return summary;
}

}  // namespace pano4d
