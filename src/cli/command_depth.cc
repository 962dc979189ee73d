// pano4d depth: the frames later stages work on (WS/pano4d/frames.json),
// each with a z-depth map (WS/pano4d/depth/<name>.npy) and a dynamic mask,
// from a dataset with known cameras or from the COLMAP workspace of
// `pano4d sfm`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "colmap_ext/dynamic_masks.h"
#include "colmap_ext/model.h"
#include "evaluation/dataset.h"
#include "src/cli/app.h"
#include "src/cli/stages.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/frames.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/npy.h"
#include "src/core/progress.h"
#include "src/geometry/depth_alignment.h"
#include "src/geometry/stereo.h"

namespace pano4d::cli {
namespace fs = std::filesystem;
namespace {

// Plane-sweep stereo settings: frames are matched at most this many
// pixels on the long side (time; the fit's frames are usually smaller);
// neighbours are the kStereoNeighbours other training frames whose
// baseline / median depth is nearest kStereoBaselineRatio (wide enough to
// resolve depth, narrow enough to match), at least kStereoMinBaselineRatio,
// looking within kStereoMaxAngleDeg; the depth range is the frame's 2nd to
// 98th percentile of SfM point depths widened by kStereoRangeMargin.
constexpr int kStereoLongSide = 640;
constexpr std::size_t kStereoNeighbours = 4;
constexpr double kStereoBaselineRatio = 0.08;
constexpr double kStereoMinBaselineRatio = 0.01;
constexpr double kStereoMaxAngleDeg = 35.0;
constexpr std::pair<double, double> kStereoRangeMargin = {0.7, 1.5};
constexpr std::size_t kMinStereoPoints = 20;

// A camera with all-zero distortion is a pinhole camera; anything else must
// be undistorted first.
Camera AsPinhole(const Camera& camera, const std::string& source) {
  const CameraModelId id = camera.model_id;
  if (id == CameraModelId::kSimplePinhole || id == CameraModelId::kPinhole)
    return camera;
  const bool single = GetCameraModelInfo(id).single_focal;
  const int intrinsic = single ? 3 : 4;
  for (std::size_t i = intrinsic; i < camera.params.size(); ++i) {
    if (camera.params[i] != 0.0) {
      throw Error(source, "camera", std::string(GetCameraModelInfo(id).name),
                  "has lens distortion; pano4d fits pinhole cameras "
                  "(undistort the frames first, e.g. `pano4d sfm` runs colmap "
                  "image_undistorter)");
    }
  }
  Camera out = camera;
  out.model_id = CameraModelId::kPinhole;
  out.params = single ? std::vector<double>{camera.params[0], camera.params[0],
                                            camera.params[1], camera.params[2]}
                      : std::vector<double>(camera.params.begin(),
                                            camera.params.begin() + 4);
  return out;
}

// A depth map as CV_32F: .npy (H x W or H x W x 1) or an image OpenCV reads
// unchanged (16-bit PNG in millimetres, float TIFF/EXR).
cv::Mat ReadDepthMap(const fs::path& path) {
  if (path.extension() == ".npy") {
    const NpyArray a = ReadNpy(path);
    if (a.shape.size() < 2 || (a.shape.size() == 3 && a.shape[2] != 1) ||
        a.shape.size() > 3) {
      throw Error(path.string(), "shape", std::to_string(a.shape.size()) + "-d",
                  "expected H x W or H x W x 1");
    }
    const std::vector<float> v = a.ToFloats();
    cv::Mat m(static_cast<int>(a.shape[0]), static_cast<int>(a.shape[1]),
              CV_32F);
    std::copy(v.begin(), v.end(), m.ptr<float>());
    return m;
  }
  const cv::Mat raw = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (raw.empty() || raw.channels() != 1) {
    throw Error(path.string(), "", "",
                "not a single-channel depth image (use .npy, 16-bit PNG in "
                "millimetres, or float TIFF/EXR)");
  }
  cv::Mat m;
  raw.convertTo(m, CV_32F, raw.depth() == CV_16U ? 1e-3 : 1.0);
  return m;
}

// Non-finite and negative values become 0 (no depth).
void CleanDepth(cv::Mat* depth) {
  depth->forEach<float>([](float& d, const int*) {
    if (!std::isfinite(d) || d < 0) d = 0;
  });
}

void WriteDepth(const fs::path& path, const cv::Mat& depth) {
  std::vector<float> v(depth.begin<float>(), depth.end<float>());
  WriteNpy(path, NpyArray::FromFloats({depth.rows, depth.cols}, v));
}

// Kubric-4D stores the distance along each pixel's ray; z = distance / |ray|
// with the ray (x_n, y_n, 1).
void RayDistanceToZ(const Camera& pinhole, cv::Mat* depth) {
  const double fx = pinhole.params[0], fy = pinhole.params[1];
  const double cx = pinhole.params[2], cy = pinhole.params[3];
  for (int y = 0; y < depth->rows; ++y) {
    for (int x = 0; x < depth->cols; ++x) {
      const double xn = (x + 0.5 - cx) / fx, yn = (y + 0.5 - cy) / fy;
      depth->at<float>(y, x) = static_cast<float>(
          depth->at<float>(y, x) / std::sqrt(xn * xn + yn * yn + 1.0));
    }
  }
}

// Dynamic masks for frames that have none on disk: flow and epipolar
// geometry over each camera's frames in time order (colmap_ext).
void ComputeMissingMasks(const fs::path& dir,
                         std::vector<WorkspaceFrame>* frames) {
  std::map<std::string, std::vector<WorkspaceFrame*>> by_camera;
  for (WorkspaceFrame& f : *frames) {
    if (!f.dynamic_mask.empty()) continue;
    const std::string key = std::to_string(f.camera.camera.width) + "x" +
                            std::to_string(f.camera.camera.height);
    by_camera[key].push_back(&f);
  }
  for (auto& [key, list] : by_camera) {
    std::stable_sort(list.begin(), list.end(),
                     [](auto* a, auto* b) { return a->time < b->time; });
    std::vector<cv::Mat> images;
    std::vector<std::string> names;
    for (WorkspaceFrame* f : list) {
      images.push_back(ReadImage(f->rgb).mat());
      names.push_back(f->name + ".png");
    }
    DynamicMaskStats stats;
    const std::vector<cv::Mat> masks = ComputeDynamicMasks(images, {}, &stats);
    WriteDynamicMasks(masks, names, dir);
    for (std::size_t i = 0; i < list.size(); ++i)
      list[i]->dynamic_mask = MaskPathFor(dir, names[i]);
    PANO4D_LOG(kInfo) << "depth: dynamic masks " << stats.BriefReport();
  }
}

// A dataset frame's name, time, pinhole camera and image.
WorkspaceFrame FrameOf(const DatasetFrame& d) {
  WorkspaceFrame f;
  f.name = d.id;
  f.time = d.time_id;
  f.camera = d.camera;
  f.camera.camera = AsPinhole(d.camera.camera, d.rgb.string());
  f.rgb = d.rgb;
  return f;
}

WorkspaceFrames FramesFromDataset(const DepthCommandOptions& o) {
  const Dataset ds = LoadDataset(o.dataset, o.factor);
  WorkspaceFrames frames;
  frames.source = "dataset " + fs::absolute(o.dataset).string();
  frames.depth_source = kDepthFromDataset;
  frames.dataset = fs::absolute(o.dataset);
  frames.dataset_factor = ds.factor;
  frames.num_times = ds.num_times;
  const fs::path depth_dir = o.workspace / "pano4d" / "depth";
  ProgressBar bar("depth", static_cast<std::int64_t>(ds.train.size()));
  std::int64_t missing_depth = 0;
  for (const DatasetFrame& d : ds.train) {
    WorkspaceFrame f = FrameOf(d);
    if (!d.depth.empty()) {
      cv::Mat depth = ReadDepthMap(d.depth);
      if (depth.cols != f.camera.camera.width ||
          depth.rows != f.camera.camera.height) {
        throw Error(
            d.depth.string(), "size",
            std::to_string(depth.cols) + "x" + std::to_string(depth.rows),
            "differs from its frame's camera");
      }
      CleanDepth(&depth);
      if (ds.kind == DatasetKind::kKubric4D)
        RayDistanceToZ(f.camera.camera, &depth);
      f.depth = depth_dir / (f.name + ".npy");
      WriteDepth(f.depth, depth);
    } else {
      ++missing_depth;
    }
    // The synthetic generator's ground-truth dynamic masks, when present.
    const fs::path gt_mask = o.dataset / "dynamic" /
                             (std::to_string(ds.factor) + "x") /
                             (d.id + ".png");
    if (fs::exists(gt_mask)) f.dynamic_mask = gt_mask;
    frames.train.push_back(std::move(f));
    bar.Add();
  }
  bar.Finish();
  if (missing_depth > 0 && o.depth_dir.empty()) {
    throw Error(o.dataset.string(), "depth",
                std::to_string(missing_depth) + " frames",
                "the dataset has no depth for them; pass --depth-dir with "
                "depth maps from another tool (aligned to `pano4d sfm "
                "--dataset` points)");
  }
  for (const DatasetFrame& d : ds.val) {
    WorkspaceFrame f = FrameOf(d);
    f.covisible = d.covisible;
    frames.val.push_back(std::move(f));
  }
  return frames;
}

// The frames of `pano4d sfm`'s model (undistorted, pinhole), in name order;
// every holdout-th one (LLFF's convention: i % holdout == 0) validates.
WorkspaceFrames FramesFromWorkspace(const DepthCommandOptions& o,
                                    ColmapModel* model) {
  const fs::path sfm_json = o.workspace / "pano4d" / "sfm.json";
  if (!fs::exists(sfm_json)) {
    throw Error(sfm_json.string(), "", "",
                "missing; run `pano4d sfm` first, or pass --dataset");
  }
  const Json sfm = ReadJson(sfm_json);
  const fs::path model_dir =
      o.workspace / GetJson<std::string>(sfm, "model", sfm_json.string());
  const fs::path images =
      o.workspace / GetJson<std::string>(sfm, "images", sfm_json.string());
  *model = ReadModel(model_dir);
  std::vector<const ColmapImage*> sorted;
  for (const ColmapImage& image : model->images) sorted.push_back(&image);
  std::sort(sorted.begin(), sorted.end(),
            [](auto* a, auto* b) { return a->name < b->name; });
  WorkspaceFrames frames;
  frames.source = "colmap " + fs::absolute(model_dir).string();
  frames.num_times = static_cast<int>(sorted.size());
  const fs::path masks = o.workspace / "pano4d" / "tracks" / "dynamic";
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    WorkspaceFrame f;
    f.name = fs::path(sorted[i]->name).stem().string();
    f.time = static_cast<int>(i);
    f.camera = model->PosedCameraOf(*sorted[i], model_dir.string());
    f.camera.camera = AsPinhole(f.camera.camera, model_dir.string());
    f.rgb = images / sorted[i]->name;
    const fs::path mask = MaskPathFor(masks, sorted[i]->name);
    if (fs::exists(mask)) {
      const cv::Mat m = ReadMask(mask);
      if (m.cols == f.camera.camera.width && m.rows == f.camera.camera.height)
        f.dynamic_mask = mask;
    }
    const bool held_out = o.holdout > 0 && i % o.holdout == 0;
    (held_out ? frames.val : frames.train).push_back(std::move(f));
  }
  return frames;
}

// The SfM points the frame's image observes: pixel and z-depth in its
// camera (the model's image named <frame>.<ext>); none when it has none.
std::vector<DepthSample> SfmSamples(const ColmapModel& model,
                                    const WorkspaceFrame& f) {
  std::vector<DepthSample> samples;
  for (const ColmapImage& image : model.images) {
    if (fs::path(image.name).stem().string() != f.name) continue;
    for (const ColmapPoint2D& p : image.points2D) {
      if (!p.HasPoint3D()) continue;
      const ColmapPoint3D* point = model.FindPoint3D(p.point3D_id);
      if (!point) continue;
      const double z = (f.camera.cam_from_world * point->xyz).z();
      if (z > 0) samples.push_back({p.xy, z});
    }
  }
  return samples;
}

// External depth maps (`--depth-dir`, one per frame named <name>.npy, .png,
// .tiff or .exr, any resolution) brought onto the SfM points' scale with a
// robust scale and shift per frame.
void AlignExternalDepth(const DepthCommandOptions& o, const ColmapModel& model,
                        WorkspaceFrames* frames) {
  const fs::path out_dir = o.workspace / "pano4d" / "depth";
  nlohmann::json report = nlohmann::json::array();
  ProgressBar bar("depth", static_cast<std::int64_t>(frames->train.size()));
  int failed = 0;
  for (WorkspaceFrame& f : frames->train) {
    fs::path file;
    for (const char* ext : {".npy", ".png", ".tiff", ".tif", ".exr"}) {
      if (fs::exists(o.depth_dir / (f.name + ext))) {
        file = o.depth_dir / (f.name + ext);
        break;
      }
    }
    if (file.empty()) {
      throw Error(o.depth_dir.string(), "frame", f.name,
                  "no depth map named " + f.name +
                      ".npy/.png/.tiff/.exr (one per frame is needed)");
    }
    cv::Mat depth = ReadDepthMap(file);
    CleanDepth(&depth);
    const int w = f.camera.camera.width, h = f.camera.camera.height;
    if (depth.cols != w || depth.rows != h) {
      cv::Mat resized;
      // Nearest: interpolating across depth edges invents surfaces.
      cv::resize(depth, resized, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
      depth = resized;
    }
    const std::vector<DepthSample> samples = SfmSamples(model, f);
    try {
      const DepthAlignment a = AlignDepth(depth, samples);
      depth.forEach<float>([&](float& d, const int*) {
        d = d > 0 ? std::max(0.0f, static_cast<float>(a.scale * d + a.shift))
                  : 0.0f;
      });
      f.depth = out_dir / (f.name + ".npy");
      WriteDepth(f.depth, depth);
      report.push_back({{"frame", f.name},
                        {"scale", a.scale},
                        {"shift", a.shift},
                        {"samples", a.samples},
                        {"inliers", a.inliers},
                        {"median_relative_error", a.median_relative_error}});
    } catch (const Error& e) {
      ++failed;
      PANO4D_LOG(kWarning) << "depth: frame " << f.name
                           << " left without depth: " << e.what();
    }
    bar.Add();
  }
  bar.Finish();
  WriteJson(o.workspace / "pano4d" / "depth" / "alignment.json", report);
  if (failed == static_cast<int>(frames->train.size())) {
    throw Error(o.depth_dir.string(), "alignment", "0 frames",
                "no depth map could be aligned to the SfM points (see the "
                "warnings above)");
  }
}

// Plane-sweep stereo depth for every training frame of a COLMAP workspace
// (DESIGN.md "depth"): neighbours among the other training frames chosen by
// baseline, the depth range from the frame's sparse points, moving pixels
// removed (the object moved between the frames); the SfM points check the
// result (scale and median relative error in alignment.json).
void StereoDepth(const DepthCommandOptions& o, const ColmapModel& model,
                 WorkspaceFrames* frames) {
  struct Info {
    double near = 0, far = 0, median = 0;
    std::vector<DepthSample> samples;
  };
  std::vector<Info> info(frames->train.size());
  std::vector<double> all_depths;
  for (std::size_t i = 0; i < frames->train.size(); ++i) {
    info[i].samples = SfmSamples(model, frames->train[i]);
    std::vector<double> z;
    for (const DepthSample& sample : info[i].samples) z.push_back(sample.z);
    std::sort(z.begin(), z.end());
    if (z.size() >= kMinStereoPoints) {
      info[i].near = kStereoRangeMargin.first * z[z.size() * 2 / 100];
      info[i].far = kStereoRangeMargin.second * z[z.size() * 98 / 100];
      info[i].median = z[z.size() / 2];
    }
    all_depths.insert(all_depths.end(), z.begin(), z.end());
  }
  if (all_depths.size() < kMinStereoPoints) {
    throw Error(o.workspace.string(), "sparse points",
                std::to_string(all_depths.size()),
                "too few SfM points to bound the stereo depth range");
  }
  std::sort(all_depths.begin(), all_depths.end());
  for (Info& i : info) {
    if (i.median > 0) continue;
    i.near = kStereoRangeMargin.first * all_depths[all_depths.size() * 2 / 100];
    i.far =
        kStereoRangeMargin.second * all_depths[all_depths.size() * 98 / 100];
    i.median = all_depths[all_depths.size() / 2];
  }

  // Grey frames at the working size.
  std::vector<StereoView> views(frames->train.size());
  std::vector<cv::Mat> dynamic(frames->train.size());
  for (std::size_t i = 0; i < frames->train.size(); ++i) {
    const WorkspaceFrame& f = frames->train[i];
    const Image image = ReadImage(f.rgb);
    const int w = f.camera.camera.width, h = f.camera.camera.height;
    const double s = std::min(1.0, double(kStereoLongSide) / std::max(w, h));
    const int sw = std::max(1, static_cast<int>(std::lround(w * s)));
    const int sh = std::max(1, static_cast<int>(std::lround(h * s)));
    cv::Mat grey, small;
    cv::cvtColor(image.mat(), grey, cv::COLOR_RGB2GRAY);
    cv::resize(grey, small, cv::Size(sw, sh), 0, 0, cv::INTER_AREA);
    views[i].grey = small;
    views[i].camera = f.camera;
    views[i].camera.camera = f.camera.camera.Rescaled(sw, sh);
    if (!f.dynamic_mask.empty()) dynamic[i] = ReadMask(f.dynamic_mask);
  }

  const fs::path out_dir = o.workspace / "pano4d" / "depth";
  nlohmann::json report = nlohmann::json::array();
  ProgressBar bar("stereo", static_cast<std::int64_t>(views.size()));
  for (std::size_t i = 0; i < views.size(); ++i) {
    WorkspaceFrame& f = frames->train[i];
    // Neighbours: baseline / median depth nearest kStereoBaselineRatio, at
    // least kStereoMinBaselineRatio, viewing directions within
    // kStereoMaxAngleDeg.
    const Eigen::Vector3d c = f.camera.Center();
    const Eigen::Vector3d axis =
        f.camera.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
    std::vector<std::pair<double, std::size_t>> candidates;
    for (std::size_t j = 0; j < views.size(); ++j) {
      if (j == i) continue;
      const PosedCamera& other = frames->train[j].camera;
      const double ratio = (other.Center() - c).norm() / info[i].median;
      const Eigen::Vector3d other_axis =
          other.cam_from_world.rotation.conjugate() * Eigen::Vector3d::UnitZ();
      const double angle =
          std::acos(std::clamp(axis.dot(other_axis), -1.0, 1.0)) * 180 / M_PI;
      if (ratio < kStereoMinBaselineRatio || angle > kStereoMaxAngleDeg)
        continue;
      candidates.push_back(
          {std::abs(std::log(ratio / kStereoBaselineRatio)), j});
    }
    std::sort(candidates.begin(), candidates.end());
    std::vector<StereoView> neighbours;
    for (std::size_t k = 0; k < candidates.size() && k < kStereoNeighbours; ++k)
      neighbours.push_back(views[candidates[k].second]);
    bar.Add();
    if (neighbours.empty()) {
      PANO4D_LOG(kWarning) << "depth: frame " << f.name
                           << " has no stereo neighbour with enough baseline; "
                              "left without depth";
      continue;
    }
    const cv::Mat small =
        PlaneSweepDepth(views[i], neighbours, info[i].near, info[i].far);
    cv::Mat depth;
    cv::resize(small, depth,
               cv::Size(f.camera.camera.width, f.camera.camera.height), 0, 0,
               cv::INTER_NEAREST);
    if (!dynamic[i].empty()) depth.setTo(0.0f, dynamic[i] >= 128);
    f.depth = out_dir / (f.name + ".npy");
    WriteDepth(f.depth, depth);
    nlohmann::json entry = {
        {"frame", f.name},
        {"neighbours", neighbours.size()},
        {"near", info[i].near},
        {"far", info[i].far},
        {"valid_fraction",
         cv::countNonZero(depth) / static_cast<double>(depth.total())}};
    try {
      const DepthAlignment a = AlignDepth(depth, info[i].samples);
      entry["check_scale"] = a.scale;
      entry["check_shift"] = a.shift;
      entry["check_median_relative_error"] = a.median_relative_error;
    } catch (const Error& e) {
      entry["check"] = e.what();
    }
    report.push_back(entry);
  }
  bar.Finish();
  WriteJson(out_dir / "stereo.json", report);
}

}  // namespace

int RunDepthCommand(const DepthCommandOptions& o) {
  if (o.factor < 1) {
    throw Error("--factor", "", std::to_string(o.factor), "must be >= 1");
  }
  if (o.holdout < 0 || o.holdout == 1) {
    throw Error("--holdout", "", std::to_string(o.holdout),
                "must be 0 (none) or at least 2");
  }
  EnsureDirectory(o.workspace / "pano4d" / "depth");
  WorkspaceFrames frames;
  if (!o.dataset.empty()) {
    frames = FramesFromDataset(o);
    ComputeMissingMasks(o.workspace / "pano4d" / "tracks" / "dynamic",
                        &frames.train);
  } else {
    ColmapModel model;
    frames = FramesFromWorkspace(o, &model);
    // Masks first: stereo leaves moving pixels without depth. The masks of
    // `pano4d sfm` belong to the frames before undistortion; where the
    // undistorted frames differ in size they are computed again on these.
    ComputeMissingMasks(
        o.workspace / "pano4d" / "tracks" / "dynamic_undistorted",
        &frames.train);
    if (o.depth_dir.empty()) {
      StereoDepth(o, model, &frames);
      frames.depth_source = kDepthFromStereo;
    } else {
      AlignExternalDepth(o, model, &frames);
      frames.depth_source = kDepthFromExternal;
    }
  }
  WriteWorkspaceFrames(o.workspace, frames);
  int with_depth = 0;
  for (const WorkspaceFrame& f : frames.train) with_depth += !f.depth.empty();
  std::printf(
      "pano4d depth: %zu training frames (%d with depth), %zu validation "
      "frames, %d times\n  frames: %s\n",
      frames.train.size(), with_depth, frames.val.size(), frames.num_times,
      FramesPath(o.workspace).c_str());
  return kExitOk;
}

void AddDepthCommand(CLI::App& app, Action* action) {
  auto o = std::make_shared<DepthCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "depth",
      "Per-frame z-depth and dynamic masks for fitting: from a dataset with "
      "depth, or external depth maps aligned to the SfM points; writes "
      "WS/pano4d/frames.json");
  sub->add_option("--workspace", o->workspace, "The workspace (created)")
      ->required();
  sub->add_option("--dataset", o->dataset,
                  "A dataset with known cameras (DyCheck layout, e.g. from "
                  "`pano4d synth`; Nvidia; Kubric-4D): its cameras, depth "
                  "and validation split")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--factor", o->factor,
                  "Dataset resolution divisor (DyCheck evaluates at 2)")
      ->capture_default_str();
  sub->add_option("--depth-dir", o->depth_dir,
                  "Depth maps from another tool, <frame>.npy/.png (mm)/.tiff/"
                  ".exr: scale and shift fitted per frame to the SfM points "
                  "(Ceres, Cauchy loss)")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--holdout", o->holdout,
                  "Without a dataset: every N-th frame (i % N == 0) is held "
                  "out for validation (0: none)")
      ->capture_default_str();
  sub->callback([action, o] { *action = [o] { return RunDepthCommand(*o); }; });
}

}  // namespace pano4d::cli
