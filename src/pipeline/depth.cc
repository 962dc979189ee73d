#include "src/pipeline/depth.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <opencv2/imgproc.hpp>

#include "colmap_ext/masks.h"
#include "colmap_ext/model.h"
#include "src/core/camera.h"
#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/progress.h"
#include "src/core/stamp.h"
#include "src/core/strings.h"
#include "src/core/timer.h"
#include "src/datasets/dataset.h"
#include "src/datasets/depth_map.h"
#include "src/geometry/depth_alignment.h"
#include "src/geometry/motion_segmentation.h"
#include "src/pipeline/priors.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// Throws an Error naming `file` when `image` is not the camera's size.
void CheckSize(const cv::Mat& image, const fs::path& file,
               const Camera& camera) {
  if (image.cols == camera.width && image.rows == camera.height) return;
  throw Error(file.string(), "size", SizeText(image.cols, image.rows),
              "differs from its frame's camera (" +
                  SizeText(camera.width, camera.height) + ")");
}

// Dynamic masks for frames that have none on disk: flow and epipolar
// geometry over each camera's frames in time order (motion_segmentation.h).
void ComputeMissingMasks(const fs::path& dir,
                         std::vector<WorkspaceFrame>* frames) {
  std::map<std::string, std::vector<WorkspaceFrame*>> by_camera;
  for (WorkspaceFrame& f : *frames) {
    if (!f.dynamic_mask.empty()) continue;
    const std::string key =
        SizeText(f.camera.camera.width, f.camera.camera.height);
    by_camera[key].push_back(&f);
  }
  for (auto& [key, list] : by_camera) {
    std::stable_sort(list.begin(), list.end(),
                     [](auto* a, auto* b) { return a->time < b->time; });
    std::vector<cv::Mat> images;
    std::vector<std::string> names;
    for (WorkspaceFrame* f : list) {
      images.push_back(ReadImage(f->rgb).mat());
      CheckSize(images.back(), f->rgb, f->camera.camera);
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

// The dataset's frames at o.factor; with `copy_depth` their depth maps are
// copied into the workspace (as z-depth), otherwise a later step gives them
// depth.
WorkspaceFrames FramesFromDataset(const Workspace& ws, const DepthOptions& o,
                                  const Dataset& ds, bool copy_depth) {
  WorkspaceFrames frames;
  frames.source = "dataset " + fs::absolute(o.dataset).string();
  frames.dataset = fs::absolute(o.dataset);
  frames.dataset_factor = ds.factor;
  frames.num_times = ds.num_times;
  ProgressBar bar("depth", static_cast<std::int64_t>(ds.train.size()));
  for (const DatasetFrame& d : ds.train) {
    WorkspaceFrame f = FrameOf(d);
    if (copy_depth) {
      f.depth = ws.depth_map(f.name);
      const cv::Mat depth = ReadDepth(d);
      if (cv::countNonZero(depth) == 0) {
        PANO4D_LOG(kWarning)
            << d.depth.string()
            << ": no valid depth (every pixel NaN, negative or 0); the "
               "frame gets no depth loss";
      }
      WriteDepthMap(f.depth, depth);
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
  for (const DatasetFrame& d : ds.val) {
    WorkspaceFrame f = FrameOf(d);
    f.covisible = d.covisible;
    // Read now, not at the fit's first validation.
    if (!f.covisible.empty())
      CheckSize(ReadMask(f.covisible), f.covisible, d.camera.camera);
    frames.val.push_back(std::move(f));
  }
  return frames;
}

// The COLMAP model that `pano4d sfm` (or run's adoption of a COLMAP
// workspace) recorded in WS/pano4d/sfm.json, and the folder of its images.
ColmapModel ReadSfmModel(const Workspace& ws, fs::path* model_dir,
                         fs::path* images) {
  const fs::path sfm_json = ws.sfm_json();
  if (!fs::exists(sfm_json)) {
    throw Error(sfm_json.string(), "", "",
                "missing; run `pano4d sfm` first (with --dataset for a "
                "dataset's cameras)");
  }
  const Json sfm = ReadJson(sfm_json);
  *model_dir =
      ws.root() / GetJson<std::string>(sfm, "model", sfm_json.string());
  *images = ws.root() / GetJson<std::string>(sfm, "images", sfm_json.string());
  return ReadModel(*model_dir);
}

// The frames of `pano4d sfm`'s model (undistorted, pinhole), in the order
// people number files (NaturalLess, as sfm read them);
// every holdout-th one (LLFF's convention: i % holdout == 0) validates.
WorkspaceFrames FramesFromWorkspace(const Workspace& ws, const DepthOptions& o,
                                    ColmapModel* model) {
  fs::path model_dir, images;
  *model = ReadSfmModel(ws, &model_dir, &images);
  std::vector<const ColmapImage*> sorted;
  for (const ColmapImage& image : model->images) sorted.push_back(&image);
  std::sort(sorted.begin(), sorted.end(),
            [](auto* a, auto* b) { return NaturalLess(a->name, b->name); });
  WorkspaceFrames frames;
  frames.source = "colmap " + fs::absolute(model_dir).string();
  frames.num_times = static_cast<int>(sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    WorkspaceFrame f;
    f.name = fs::path(sorted[i]->name).stem().string();
    f.time = static_cast<int>(i);
    f.camera = model->PosedCameraOf(*sorted[i], model_dir.string());
    f.camera.camera = AsPinhole(f.camera.camera, model_dir.string());
    f.rgb = images / sorted[i]->name;
    const fs::path mask = MaskPathFor(ws.dynamic_masks(), sorted[i]->name);
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
    // The points' pixels belong to the model's image size.
    const ColmapCamera* camera = model.FindCamera(image.camera_id);
    if (camera &&
        (camera->width != static_cast<std::uint64_t>(f.camera.camera.width) ||
         camera->height !=
             static_cast<std::uint64_t>(f.camera.camera.height))) {
      throw Error(image.name, "size", SizeText(camera->width, camera->height),
                  "the SfM model's image differs from the frame (" +
                      SizeText(f.camera.camera.width, f.camera.camera.height) +
                      "); run `pano4d sfm --dataset` at the same --factor");
    }
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

// External depth maps (one per frame named <name>.npy, .png, .tiff or
// .exr, any resolution) brought onto the SfM points' scale with a robust
// scale and shift per frame; taken as they are when the model has no
// points (a rotation-only or static camera).
void AlignExternalDepth(const Workspace& ws, const DepthOptions& o,
                        const ColmapModel& model, WorkspaceFrames* frames) {
  nlohmann::json report = nlohmann::json::array();
  ProgressBar bar("depth", static_cast<std::int64_t>(frames->train.size()));
  int failed = 0;
  std::vector<std::string> names;
  for (const WorkspaceFrame& f : frames->train) names.push_back(f.name);
  const std::vector<fs::path> files = ExternalDepthFiles(o.depth_dir, names);
  for (std::size_t i = 0; i < frames->train.size(); ++i) {
    WorkspaceFrame& f = frames->train[i];
    cv::Mat depth = ReadDepthMap(files[i]);
    const int w = f.camera.camera.width, h = f.camera.camera.height;
    if (depth.cols != w || depth.rows != h) {
      // Resized, but never stretched: another aspect ratio is another
      // frame's map, or a transposed one.
      const double a = static_cast<double>(depth.cols) / depth.rows;
      if (std::abs(a / (static_cast<double>(w) / h) - 1.0) >
          kMaxAspectDifference) {
        throw Error(files[i].string(), "size", SizeText(depth.cols, depth.rows),
                    "another aspect ratio than its frame " + f.name + " (" +
                        SizeText(w, h) +
                        "): another frame's map, or width and height swapped");
      }
      cv::Mat resized;
      // Nearest: interpolating across depth edges invents surfaces.
      cv::resize(depth, resized, cv::Size(w, h), 0, 0, cv::INTER_NEAREST);
      depth = resized;
    }
    if (model.points3D.empty()) {
      // A rotation-only or static camera's model (one centre) has no
      // points to align to: the maps are the user's metric depth.
      f.depth = ws.depth_map(f.name);
      WriteDepthMap(f.depth, depth);
      report.push_back({{"frame", f.name},
                        {"scale", 1.0},
                        {"shift", 0.0},
                        {"samples", 0},
                        {"as_given", "the model has no points"}});
      bar.Add();
      continue;
    }
    try {
      const DepthAlignment a = AlignDepth(depth, SfmSamples(model, f));
      depth.forEach<float>([&](float& d, const int*) {
        d = d > 0 ? std::max(0.0f, static_cast<float>(a.scale * d + a.shift))
                  : 0.0f;
      });
      f.depth = ws.depth_map(f.name);
      WriteDepthMap(f.depth, depth);
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
  WriteJson(ws.depth() / "alignment.json", report);
  if (failed == static_cast<int>(frames->train.size())) {
    throw Error(o.depth_dir.string(), "alignment", "0 frames",
                "no depth map could be aligned to the SfM points (see the "
                "warnings above)");
  }
}

// Each training frame grey at the working size (its longer side at most
// `long_side`), with its camera rescaled, and its dynamic mask if any.
std::vector<StereoView> StereoViews(const WorkspaceFrames& frames,
                                    int long_side,
                                    std::vector<cv::Mat>* dynamic) {
  const std::size_t n = frames.train.size();
  std::vector<StereoView> views(n);
  for (std::size_t i = 0; i < n; ++i) {
    const WorkspaceFrame& f = frames.train[i];
    const Image image = ReadImage(f.rgb);
    const int w = f.camera.camera.width, h = f.camera.camera.height;
    CheckSize(image.mat(), f.rgb, f.camera.camera);
    const double s = std::min(1.0, double(long_side) / std::max(w, h));
    const int sw = std::max(1, static_cast<int>(std::lround(w * s)));
    const int sh = std::max(1, static_cast<int>(std::lround(h * s)));
    cv::Mat grey, small;
    cv::cvtColor(image.mat(), grey, cv::COLOR_RGB2GRAY);
    cv::resize(grey, small, cv::Size(sw, sh), 0, 0, cv::INTER_AREA);
    views[i].grey = small;
    views[i].camera = f.camera;
    views[i].camera.camera = f.camera.camera.Rescaled(sw, sh);
    if (!f.dynamic_mask.empty()) {
      (*dynamic)[i] = ReadMask(f.dynamic_mask);
      CheckSize((*dynamic)[i], f.dynamic_mask, f.camera.camera);
    }
  }
  return views;
}

// Plane-sweep stereo depth for every training frame, on the poses of the
// COLMAP model (a dataset's own cameras when `pano4d sfm --dataset` made
// it; DESIGN.md "depth"): neighbours among the other training frames chosen by
// baseline, the depth range from the frame's sparse points, moving pixels
// removed (the object moved between the frames); the SfM points check the
// result (scale and median relative error in stereo.json).
void StereoDepth(const Workspace& ws, const DepthOptions& o,
                 const ColmapModel& model, WorkspaceFrames* frames) {
  const std::size_t n = frames->train.size();
  std::vector<StereoRange> ranges(n);
  std::vector<std::vector<DepthSample>> samples(n);
  std::vector<double> all_depths;
  std::vector<PosedCamera> cameras;
  for (std::size_t i = 0; i < n; ++i) {
    samples[i] = SfmSamples(model, frames->train[i]);
    std::vector<double> z;
    for (const DepthSample& sample : samples[i]) z.push_back(sample.z);
    all_depths.insert(all_depths.end(), z.begin(), z.end());
    ranges[i] = StereoRangeOf(std::move(z)).value_or(StereoRange{});
    cameras.push_back(frames->train[i].camera);
  }
  const std::optional<StereoRange> scene = StereoRangeOf(all_depths);
  if (!scene) {
    throw Error(ws.root().string(), "sparse points",
                std::to_string(all_depths.size()),
                "too few SfM points to bound the stereo depth range");
  }
  // A frame that sees too few points sweeps the whole scene's range.
  for (StereoRange& r : ranges)
    if (!(r.median > 0)) r = *scene;

  std::vector<cv::Mat> dynamic(n);
  const std::vector<StereoView> views =
      StereoViews(*frames, o.stereo_long_side, &dynamic);

  nlohmann::json report = nlohmann::json::array();
  ProgressBar bar("stereo", static_cast<std::int64_t>(n));
  for (std::size_t i = 0; i < n; ++i) {
    WorkspaceFrame& f = frames->train[i];
    std::vector<StereoView> neighbours;
    for (std::size_t j :
         SelectStereoNeighbours(cameras, i, ranges[i].median, o.neighbours))
      neighbours.push_back(views[j]);
    bar.Add();
    if (neighbours.empty()) {
      PANO4D_LOG(kWarning) << "depth: frame " << f.name
                           << " has no stereo neighbour with enough baseline; "
                              "left without depth";
      continue;
    }
    const cv::Mat small = PlaneSweepDepth(views[i], neighbours, ranges[i].near,
                                          ranges[i].far, o.sweep);
    cv::Mat depth;
    cv::resize(small, depth,
               cv::Size(f.camera.camera.width, f.camera.camera.height), 0, 0,
               cv::INTER_NEAREST);
    if (!dynamic[i].empty()) depth.setTo(0.0f, dynamic[i] >= 128);
    f.depth = ws.depth_map(f.name);
    WriteDepthMap(f.depth, depth);
    nlohmann::json entry = {
        {"frame", f.name},
        {"neighbours", neighbours.size()},
        {"near", ranges[i].near},
        {"far", ranges[i].far},
        {"valid_fraction",
         cv::countNonZero(depth) / static_cast<double>(depth.total())}};
    try {
      const DepthAlignment a = AlignDepth(depth, samples[i]);
      entry["check_scale"] = a.scale;
      entry["check_shift"] = a.shift;
      entry["check_median_relative_error"] = a.median_relative_error;
    } catch (const Error& e) {
      entry["check"] = e.what();
    }
    report.push_back(entry);
  }
  bar.Finish();
  WriteJson(ws.depth() / "stereo.json", report);
}

// A learned map whose aligned depth misses the frame's SfM points by more
// than this (median, relative) is another scene's or a failed network
// output: the frame keeps its stereo depth, and the report names it. MiDaS
// on Balloon1 misses by 3% to 14% (its disparity is not an exact affine of
// inverse depth), and is still the only depth its moving pixels have.
constexpr double kMaxLearnedDepthError = 0.25;
// Learned depth beyond this many times the SfM points' 98th percentile is
// dropped: a disparity near 0 (the far background) maps to depths an
// affine fitted on nearer points cannot vouch for.
constexpr double kMaxLearnedDepthFactor = 4.0;

// The priors' motion masks as the training frames' dynamic masks (written
// to the workspace's masks folder): in place of those a frame would get
// (replace, before ComputeMissingMasks) or added to them (join, after).
void UsePriorMasks(const fs::path& dir, const MaskPrior& prior,
                   const std::vector<PriorFrame>& video, bool join,
                   WorkspaceFrames* frames) {
  std::map<std::string, const cv::Mat*> by_name;
  for (std::size_t j = 0; j < video.size(); ++j)
    if (!prior.masks[j].empty()) by_name[video[j].name] = &prior.masks[j];
  int used = 0;
  for (WorkspaceFrame& f : frames->train) {
    const auto it = by_name.find(f.name);
    if (it == by_name.end()) continue;
    cv::Mat mask = it->second->clone();
    if (join && !f.dynamic_mask.empty()) {
      const cv::Mat own = ReadMask(f.dynamic_mask);
      CheckSize(own, f.dynamic_mask, f.camera.camera);
      mask.setTo(kMaskOn, own >= 128);
    }
    WriteDynamicMasks({mask}, {f.name + ".png"}, dir);
    f.dynamic_mask = MaskPathFor(dir, f.name + ".png");
    ++used;
  }
  PANO4D_LOG(kInfo) << "depth: motion masks from " << prior.layout->name
                    << (join ? " joined to the computed ones" : "") << " for "
                    << used << " of " << frames->train.size()
                    << " training frames";
}

// A frame's learned depth in the SfM points' units (AlignDepthModel: an
// affine fit in inverse depth for disparity, a scale for metric depth), or
// as given when the model has no points. nullopt when the fit fails or does
// not fit the points, said in `entry` and the log.
std::optional<cv::Mat> AlignedLearnedDepth(
    const cv::Mat& map, const std::vector<DepthSample>& samples, bool no_points,
    bool metric, double max_depth, const std::string& name,
    nlohmann::json* entry) {
  if (no_points) {
    (*entry)["as_given"] = "the model has no points";
    return map.clone();
  }
  try {
    const DepthAlignment a = AlignDepthModel(
        map, samples,
        metric ? DepthModel::kScale : DepthModel::kAffineDisparity);
    (*entry)["scale"] = a.scale;
    (*entry)["shift"] = a.shift;
    (*entry)["samples"] = a.samples;
    (*entry)["inliers"] = a.inliers;
    (*entry)["median_relative_error"] = a.median_relative_error;
    if (a.median_relative_error > kMaxLearnedDepthError) {
      throw Error(name, "median relative error",
                  std::to_string(a.median_relative_error),
                  "above " + std::to_string(kMaxLearnedDepthError) +
                      ": the learned depth does not fit the SfM points");
    }
    return ApplyDepthAlignment(map, a, max_depth);
  } catch (const Error& e) {
    (*entry)["failed"] = e.what();
    PANO4D_LOG(kWarning) << "depth: frame " << name
                         << " keeps its stereo depth only: " << e.what();
    return std::nullopt;
  }
}

// The frame's depth map with its moving pixels and its static holes filled
// from `learned` (first corrected locally towards the stereo depth),
// written to WS/pano4d/depth/<frame>.npy; the pixels filled in `entry`.
void FillFromLearnedDepth(const Workspace& ws, cv::Mat learned,
                          double smoothing, WorkspaceFrame* f,
                          nlohmann::json* entry) {
  cv::Mat depth = f->depth.empty()
                      ? cv::Mat(learned.size(), CV_32F, cv::Scalar(0))
                      : ReadDepthMap(f->depth);
  cv::Mat moving;
  if (!f->dynamic_mask.empty()) moving = ReadMask(f->dynamic_mask) >= 128;
  if (smoothing > 0 && !f->depth.empty()) {
    cv::Mat trusted = depth > 0;
    if (!moving.empty()) trusted.setTo(0, moving);
    learned =
        CorrectDepthLocally(learned, depth, trusted, smoothing * depth.cols);
  }
  int filled_moving = 0, filled_holes = 0;
  for (int y = 0; y < depth.rows; ++y) {
    for (int x = 0; x < depth.cols; ++x) {
      const float z = learned.at<float>(y, x);
      float& d = depth.at<float>(y, x);
      const bool is_moving = !moving.empty() && moving.at<std::uint8_t>(y, x);
      if (!(z > 0) || (d > 0 && !is_moving)) continue;
      d = z;
      ++(is_moving ? filled_moving : filled_holes);
    }
  }
  (*entry)["filled_moving_pixels"] = filled_moving;
  (*entry)["filled_static_pixels"] = filled_holes;
  f->depth = ws.depth_map(f->name);
  WriteDepthMap(f->depth, depth);
}

// Each training frame's learned depth, aligned to its SfM points (an affine
// in inverse depth for disparity, a scale for metric depth) and corrected
// locally towards its stereo depth (CorrectDepthLocally, Gaussian of
// `smoothing` x the frame's width; 0: none), fills the pixels stereo cannot
// give: the moving ones (stereo matches frames taken at other times) and
// static ones without stereo support. Without SfM points (one camera
// centre) metric depth is taken as it is. Writes
// WS/pano4d/depth/priors.json: per frame the fit, its residual, the pixels
// filled, or why it failed.
void MergeLearnedDepth(const Workspace& ws, const ColmapModel& model,
                       const DepthPrior& prior, double smoothing,
                       const std::vector<PriorFrame>& video,
                       WorkspaceFrames* frames, DepthSummary* summary) {
  const bool metric = prior.layout->meaning == DepthMeaning::kMetricDepth;
  if (model.points3D.empty() && !metric) {
    throw Error(prior.layout->path.string(), "alignment", "no SfM points",
                "disparity needs sparse points to be aligned to, and this "
                "model has none (one camera centre); give metric depth");
  }
  const std::size_t n = frames->train.size();
  std::map<std::string, const cv::Mat*> by_name;
  for (std::size_t j = 0; j < video.size(); ++j)
    if (!prior.maps[j].empty()) by_name[video[j].name] = &prior.maps[j];
  std::vector<cv::Mat> maps(n);
  std::vector<double> sample_depths;
  std::vector<std::vector<DepthSample>> samples(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto it = by_name.find(frames->train[i].name);
    if (it != by_name.end()) maps[i] = *it->second;
    samples[i] = SfmSamples(model, frames->train[i]);
    for (const DepthSample& s : samples[i]) sample_depths.push_back(s.z);
  }
  double max_depth = kMaxPlausibleDepth;
  if (!sample_depths.empty()) {
    std::sort(sample_depths.begin(), sample_depths.end());
    max_depth =
        kMaxLearnedDepthFactor * sample_depths[sample_depths.size() * 98 / 100];
  }
  nlohmann::json report = nlohmann::json::array();
  ProgressBar bar("learned depth",
                  static_cast<std::int64_t>(frames->train.size()));
  for (std::size_t i = 0; i < frames->train.size(); ++i) {
    WorkspaceFrame& f = frames->train[i];
    bar.Add();
    if (maps[i].empty()) {
      summary->without_learned_depth.push_back(f.name);
      report.push_back({{"frame", f.name}, {"learned", "no file"}});
      continue;
    }
    nlohmann::json entry = {{"frame", f.name},
                            {"model", metric ? "scale" : "affine disparity"}};
    const std::optional<cv::Mat> learned =
        AlignedLearnedDepth(maps[i], samples[i], model.points3D.empty(), metric,
                            max_depth, f.name, &entry);
    if (!learned) {
      summary->alignment_failed.push_back(f.name);
      report.push_back(entry);
      continue;
    }
    FillFromLearnedDepth(ws, *learned, smoothing, &f, &entry);
    ++summary->with_learned_depth;
    report.push_back(entry);
  }
  bar.Finish();
  WriteJson(ws.depth() / "priors.json", {{"frames", report}});
}

// The moving pixels' depth of neighbouring training frames made to agree
// with the flow between them (ConsistentMovingDepthScales): each frame's
// moving depth is multiplied by exp(c_t), and priors.json gives c_t
// (`moving_depth_log_scale`) and each pair's comparison.
void MakeMovingDepthConsistent(const Workspace& ws, const FlowPrior& flow,
                               const std::vector<PriorFrame>& video,
                               const WorkspaceFrames& frames) {
  // The training frames in the video's order (PriorVideoFrames' order is
  // time order), and the flow from each to the next.
  std::map<std::string, std::size_t> video_index;
  for (std::size_t j = 0; j < video.size(); ++j) video_index[video[j].name] = j;
  std::vector<const WorkspaceFrame*> order;
  for (const WorkspaceFrame& f : frames.train)
    if (video_index.count(f.name) && !f.depth.empty() &&
        !f.dynamic_mask.empty())
      order.push_back(&f);
  std::sort(order.begin(), order.end(), [&](const auto* a, const auto* b) {
    return video_index[a->name] < video_index[b->name];
  });
  if (order.size() < 2) return;
  std::vector<cv::Mat> depth(order.size()), moving(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    depth[i] = ReadDepthMap(order[i]->depth);
    moving[i] = ReadMask(order[i]->dynamic_mask) >= 128;
  }
  std::vector<MovingDepthPair> pairs(order.size() - 1);
  nlohmann::json pair_report = nlohmann::json::array();
  for (std::size_t i = 0; i + 1 < order.size(); ++i) {
    const std::size_t from = video_index[order[i]->name];
    const std::size_t to = video_index[order[i + 1]->name];
    for (const FlowField& field : flow.fields) {
      if (field.from != static_cast<int>(from) ||
          field.to != static_cast<int>(to) ||
          field.flow.size() != depth[i].size())
        continue;
      cv::Mat trusted = moving[i].clone();
      if (!field.valid.empty()) trusted.setTo(0, field.valid == 0);
      pairs[i] =
          CompareMovingDepth(depth[i], trusted, depth[i + 1], moving[i + 1],
                             field.flow, std::max(2, depth[i].cols / 60));
    }
    pair_report.push_back({{"from", order[i]->name},
                           {"to", order[i + 1]->name},
                           {"matches", pairs[i].matches},
                           {"log_depth_ratio", pairs[i].log_depth_ratio},
                           {"log_stretch", pairs[i].log_stretch}});
  }
  const std::vector<double> scale = ConsistentMovingDepthScales(pairs);
  const fs::path report_file = ws.depth() / "priors.json";
  nlohmann::json report = ReadJson(report_file);
  for (std::size_t i = 0; i < order.size(); ++i) {
    const cv::Mat scaled = depth[i] * std::exp(scale[i]);
    scaled.copyTo(depth[i], moving[i]);
    WriteDepthMap(order[i]->depth, depth[i]);
    for (auto& entry : report.at("frames"))
      if (entry["frame"] == order[i]->name)
        entry["moving_depth_log_scale"] = scale[i];
  }
  report["moving_depth_pairs"] = pair_report;
  WriteJson(report_file, report);
  PANO4D_LOG(kInfo) << "depth: moving depth made consistent along the flow "
                       "over "
                    << order.size() << " frames";
}

// The priors' depth merged into the stereo depth (MergeLearnedDepth), and
// with flow among the priors the moving depth made consistent along it.
void UseLearnedDepth(const Workspace& ws, const DepthOptions& o,
                     const ColmapModel& model, const PriorsFolder& priors,
                     const std::vector<PriorFrame>& video,
                     WorkspaceFrames* frames, DepthSummary* summary) {
  const std::optional<DepthPrior> depth = ReadDepthPrior(priors, video);
  if (!depth) return;
  MergeLearnedDepth(ws, model, *depth, o.learned_depth_smoothing, video, frames,
                    summary);
  if (summary->with_learned_depth == 0) return;
  frames->depth_source = kDepthFromPriors;
  if (!o.consistent_moving_depth) return;
  if (const std::optional<FlowPrior> flow = ReadFlowPrior(priors, video))
    MakeMovingDepthConsistent(ws, *flow, video, *frames);
  else
    PANO4D_LOG(kInfo) << "depth: moving depth aligned per frame only: "
                         "no flow among the priors to make it "
                         "consistent along";
}

}  // namespace

void DepthOptions::Check() const {
  if (factor < 0) {
    throw Error("--factor", "", std::to_string(factor),
                "must be >= 1, or 0 for the dataset's protocol");
  }
  if (holdout < 0 || holdout == 1) {
    throw Error("--holdout", "", std::to_string(holdout),
                "must be 0 (none) or at least 2");
  }
  if (stereo_long_side < 16) {
    throw Error("depth options", "stereo_long_side",
                std::to_string(stereo_long_side), "must be at least 16");
  }
  neighbours.Check();
  sweep.Check();
}

nlohmann::json DepthOptions::ToJson() const {
  return {{"dataset", dataset.string()},
          {"depth_dir", depth_dir.string()},
          {"priors", priors.string()},
          {"prior_masks_join", prior_masks_join},
          {"learned_depth_smoothing", learned_depth_smoothing},
          {"consistent_moving_depth", consistent_moving_depth},
          {"factor", factor},
          {"holdout", holdout},
          {"stereo_long_side", stereo_long_side},
          {"neighbours",
           {{"neighbours", neighbours.neighbours},
            {"baseline_ratio", neighbours.baseline_ratio},
            {"min_baseline_ratio", neighbours.min_baseline_ratio},
            {"max_angle_degrees", neighbours.max_angle_degrees}}},
          {"sweep",
           {{"planes", sweep.planes},
            {"window", sweep.window},
            {"min_correlation", sweep.min_correlation},
            {"min_texture", sweep.min_texture}}}};
}

std::string DepthSummary::BriefReport() const {
  std::string text = StringPrintf(
      "%zu training frames (%d with depth), %zu validation frames, %d times, "
      "depth from %s",
      frames.train.size(), with_depth, frames.val.size(), frames.num_times,
      frames.depth_source.c_str());
  if (with_learned_depth > 0 || !alignment_failed.empty()) {
    text += StringPrintf("; learned depth in %d frames", with_learned_depth);
    if (!without_learned_depth.empty()) {
      text += ", none in the priors for " +
              std::to_string(without_learned_depth.size()) + " (" +
              without_learned_depth.front() +
              (without_learned_depth.size() > 1 ? ", ..." : "") + ")";
    }
    if (!alignment_failed.empty()) {
      text += ", not aligned in " + std::to_string(alignment_failed.size()) +
              " (" + alignment_failed.front() +
              (alignment_failed.size() > 1 ? ", ..." : "") +
              "; WS/pano4d/depth/priors.json says why)";
    }
  }
  return text;
}

StageRecord DepthStageRecord(const Workspace& ws, const DepthOptions& o) {
  StageRecord in(ws.root());
  // The options as they act: the protocol's factor resolved, paths however
  // they were spelt (`data/` and `/abs/data` are one input).
  DepthOptions as_used = o;
  if (!o.dataset.empty()) {
    as_used.factor = LoadDataset(o.dataset, o.factor).factor;
    as_used.dataset = fs::weakly_canonical(o.dataset);
  }
  if (!o.depth_dir.empty())
    as_used.depth_dir = fs::weakly_canonical(o.depth_dir);
  if (!o.priors.empty()) as_used.priors = fs::weakly_canonical(o.priors);
  in.Option("depth", as_used.ToJson());
  if (!o.dataset.empty()) in.File(o.dataset);
  // The model of `pano4d sfm` (or an adopted COLMAP workspace), whose
  // frames or sparse points the stage reads.
  in.File(ws.sfm_json());
  if (fs::exists(ws.sfm_json())) {
    const Json sfm = ReadJson(ws.sfm_json());
    for (const char* key : {"model", "images"}) {
      if (sfm.contains(key) && sfm[key].is_string())
        in.File(ws.root() / sfm[key].get<std::string>());
    }
  }
  in.File(ws.dynamic_masks());
  in.File(ws.undistorted_dynamic_masks());
  if (!o.depth_dir.empty()) in.File(o.depth_dir);
  if (!o.priors.empty()) in.File(o.priors);
  // Its outputs: one removed or edited by hand is noticed.
  in.File(ws.frames_json());
  in.File(ws.depth());
  return in;
}

DepthSummary RunDepth(const Workspace& ws, const DepthOptions& o) {
  o.Check();
  const Timer timer;
  const StageStamp stamp(ws, "depth");
  stamp.Remove();
  EnsureDirectory(ws.depth());
  DepthSummary summary;
  WorkspaceFrames& frames = summary.frames;
  ColmapModel model;
  // The priors folder is read first: a layout it does not hold is an error
  // before any work.
  std::optional<PriorsFolder> priors;
  if (!o.priors.empty()) priors = ScanPriors(o.priors);
  std::vector<PriorFrame> video;
  std::optional<MaskPrior> prior_masks;
  // Reads the priors' masks for the frames listed so far and, unless they
  // join the computed ones, uses them before those are computed.
  const auto masks_before = [&](const fs::path& dir) {
    if (!priors) return;
    video = PriorVideoFrames(ws, frames);
    prior_masks = ReadMaskPrior(*priors, video);
    if (prior_masks && !o.prior_masks_join)
      UsePriorMasks(dir, *prior_masks, video, false, &frames);
  };
  const auto masks_after = [&](const fs::path& dir) {
    if (prior_masks && o.prior_masks_join)
      UsePriorMasks(dir, *prior_masks, video, true, &frames);
  };
  if (!o.dataset.empty()) {
    const Dataset ds = LoadDataset(o.dataset, o.factor);
    const std::string source = DepthSourceFor(HasDepth(ds), o.depth_dir);
    // The sparse points of `pano4d sfm --dataset`, at the same factor, read
    // first: without them nothing below can finish.
    if (source != kDepthFromDataset) {
      fs::path model_dir, images;
      model = ReadSfmModel(ws, &model_dir, &images);
    }
    frames = FramesFromDataset(ws, o, ds, source == kDepthFromDataset);
    frames.depth_source = source;
    masks_before(ws.dynamic_masks());
    ComputeMissingMasks(ws.dynamic_masks(), &frames.train);
    masks_after(ws.dynamic_masks());
  } else {
    frames = FramesFromWorkspace(ws, o, &model);
    frames.depth_source = DepthSourceFor(false, o.depth_dir);
    // Masks first: stereo leaves moving pixels without depth. The masks of
    // `pano4d sfm` belong to the frames before undistortion; where the
    // undistorted frames differ in size they are computed again on these.
    masks_before(ws.undistorted_dynamic_masks());
    ComputeMissingMasks(ws.undistorted_dynamic_masks(), &frames.train);
    masks_after(ws.undistorted_dynamic_masks());
  }
  if (frames.depth_source == kDepthFromStereo)
    StereoDepth(ws, o, model, &frames);
  else if (frames.depth_source == kDepthFromExternal)
    AlignExternalDepth(ws, o, model, &frames);
  if (priors && frames.depth_source == kDepthFromStereo)
    UseLearnedDepth(ws, o, model, *priors, video, &frames, &summary);
  frames.priors = o.priors.empty() ? fs::path() : fs::absolute(o.priors);
  frames.depth_options = o.ToJson();
  WriteWorkspaceFrames(ws.root(), frames);
  for (const WorkspaceFrame& f : frames.train)
    summary.with_depth += !f.depth.empty();
  stamp.Write(DepthStageRecord(ws, o), timer.WallSeconds());
  return summary;
}

const char* DepthSourceFor(bool dataset_depth, const fs::path& depth_dir) {
  if (!depth_dir.empty()) return kDepthFromExternal;
  return dataset_depth ? kDepthFromDataset : kDepthFromStereo;
}

bool HasDepth(const Dataset& dataset) {
  if (dataset.train.empty()) return false;
  for (const DatasetFrame& f : dataset.train)
    if (f.depth.empty()) return false;
  return true;
}

std::vector<fs::path> ExternalDepthFiles(
    const fs::path& dir, const std::vector<std::string>& frames) {
  if (!fs::is_directory(dir))
    throw Error::In(dir.string(),
                    "is not a folder of depth maps (--depth-dir)");
  std::vector<fs::path> files;
  for (const std::string& name : frames) {
    fs::path file;
    for (const char* ext : {".npy", ".png", ".tiff", ".tif", ".exr"}) {
      if (fs::exists(dir / (name + ext))) {
        file = dir / (name + ext);
        break;
      }
    }
    if (file.empty()) {
      throw Error(dir.string(), "frame", name,
                  "no depth map named " + name +
                      ".npy/.png/.tiff/.exr (one per training frame is "
                      "needed)");
    }
    files.push_back(file);
  }
  return files;
}

}  // namespace pano4d
