#include "src/pano/expansion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <numeric>
#include <sstream>

#include <nlohmann/json.hpp>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/core/median.h"
#include "src/core/memory.h"
#include "src/core/npy.h"
#include "src/core/option_checks.h"
#include "src/core/progress.h"
#include "src/core/strings.h"
#include "src/geometry/inpaint.h"
#include "src/geometry/point_cloud.h"
#include "src/gs/init.h"
#include "src/pano/free_space.h"
#include "src/pano/warp.h"

namespace pano4d {
namespace {

// What one expanded view keeps in memory, bytes a pixel: for L_refine over
// every step its image and mask, and the refined frame (colour and depth)
// the next step warps from, with a margin.
constexpr double kExpandedViewBytesPerPixel = 32;

constexpr double kDegrees = M_PI / 180.0;
// An expansion step shows its own progress bar (views done) only when it
// runs longer than this: many directions or large frames; a usual step
// stays one log line.
constexpr double kStepProgressAfterSeconds = 10;
// Rendered depth is trusted where the Gaussians are this opaque: at
// semi-transparent edges the expected depth lies between surfaces.
constexpr float kWarpAlpha = 0.5f;
// A pixel of M_e that the current Gaussians already cover this much gets no
// new Gaussian (a later step sees what an earlier one added).
constexpr float kCoveredAlpha = 0.5f;

// The layout is fitted to every this-many-th pixel of each source (in x
// and y): a 480x270 source gives some 8,000 points, plenty for a few planes
// and percentiles, and RANSAC stays well under a second.
constexpr int kLayoutStride = 4;

// The layout's shell (before step 1): one Gaussian per this share of the
// box's longest edge on each face, opaque, so that where neither a frame
// nor an expanded view reached a novel view shows the face's colour
// instead of the black background. 1/48: some 6,000 Gaussians in a room, a
// few percent of a fit's.
constexpr float kShellSpacingShare = 1.0f / 48;
constexpr double kShellOpacity = 0.9;
// A shell Gaussian's footprint reaches this many spacings (its scale) from
// its centre (at opacity 0.9 it falls below 1/255 at 3.3 sigma): one whose
// centre lies just outside a frame's view still veils the frame's edge.
constexpr float kShellReach = 3.0f;

// A Gaussian within this share of the shell's spacing of a plane face lies
// on it (Layout::PlaneFaceAt): the shell's own Gaussians, and what the
// fit placed on the floor or a wall. Half: a box's bottom 8 cm in an 8 m
// room, and Gaussians floating that close to the plane, count as the plane.
constexpr float kOnPlaneSpacings = 0.5f;

float ShellSpacing(const Layout& layout) {
  return kShellSpacingShare * (layout.hi - layout.lo).maxCoeff();
}

// The layout's box holds the source cameras with this share of their
// median depth to spare on faces that are no fitted plane: a camera stands
// in the room, a step or more from the wall behind it, which no frame saw.
constexpr double kLayoutCameraMargin = 0.5;

// Colour quantised to 8 bits, as the refinement target is stored (so that a
// resumed run, which reads the PNGs, sees what the first run saw).
cv::Mat Quantised(const cv::Mat& rgb) {
  cv::Mat bytes, out;
  rgb.convertTo(bytes, CV_8UC3, 255.0);
  bytes.convertTo(out, CV_32FC3, 1.0 / 255.0);
  return out;
}

// Depth of a refined frame: the warp's where it had one, the prior's where
// it filled and knew it, elsewhere the farthest depth around the hole
// (FillDepthFromFarthest: unseen content is mostly background), no nearer
// than the layout's surface (`layout_depth`, 0 = none; may be empty).
cv::Mat RefinedDepth(const cv::Mat& warped_depth, const cv::Mat& filled_mask,
                     const cv::Mat& prior_depth, const cv::Mat& layout_depth) {
  cv::Mat depth = warped_depth.clone();
  if (!prior_depth.empty()) prior_depth.copyTo(depth, filled_mask);
  cv::Mat missing = depth <= 0;
  const int count = cv::countNonZero(missing);
  if (count == 0) return depth;
  cv::Mat filled = cv::Mat::zeros(depth.size(), CV_32FC1);
  if (count < static_cast<int>(depth.total()))
    filled = FillDepthFromFarthest(depth, missing);
  if (!layout_depth.empty()) filled = cv::max(filled, layout_depth);
  filled.copyTo(depth, missing);
  return depth;
}

// The static pixels of the sources with depth, every kLayoutStride-th, as
// a coloured cloud for FitLayout.
PointCloud StaticSourcePoints(const std::vector<cv::Mat>& rgb,
                              const std::vector<cv::Mat>& depth,
                              const std::vector<cv::Mat>& moving,
                              const std::vector<RasterCamera>& cameras) {
  PointCloud cloud;
  for (std::size_t s = 0; s < rgb.size(); ++s) {
    const RasterCamera& c = cameras[s];
    for (int y = 0; y < c.height; y += kLayoutStride) {
      for (int x = 0; x < c.width; x += kLayoutStride) {
        const float z = depth[s].at<float>(y, x);
        if (!(z > 0) || !std::isfinite(z)) continue;
        if (!moving[s].empty() && moving[s].at<std::uint8_t>(y, x)) continue;
        cloud.points.push_back(c.Unproject(x + 0.5f, y + 0.5f, z));
        const cv::Vec3f col = rgb[s].at<cv::Vec3f>(y, x);
        cloud.colors.emplace_back(col[0], col[1], col[2]);
      }
    }
  }
  return cloud;
}

// The static pixels of every training view with depth that lie past the
// layout's box (Layout::Beyond), at every pixel: a wall the frames saw
// only at their edges shows in a few hundred of them.
PointCloud PointsBeyond(const Layout& layout,
                        const std::vector<TrainingView>& views) {
  PointCloud cloud;
  if (!layout.valid) return cloud;
  for (const TrainingView& v : views) {
    if (v.depth.empty()) continue;
    const RasterCamera& c = v.camera;
    for (int y = 0; y < c.height; ++y) {
      for (int x = 0; x < c.width; ++x) {
        const std::size_t i = static_cast<std::size_t>(y) * c.width + x;
        const float z = v.depth[i];
        if (!(z > 0) || !std::isfinite(z)) continue;
        if (!v.dynamic.empty() && v.dynamic[i]) continue;
        const Eigen::Vector3f p = c.Unproject(x + 0.5f, y + 0.5f, z);
        if (!layout.Beyond(p)) continue;
        cloud.points.push_back(p);
        cloud.colors.emplace_back(v.rgb[3 * i], v.rgb[3 * i + 1],
                                  v.rgb[3 * i + 2]);
      }
    }
  }
  return cloud;
}

// The step's layout: fitted to the sources' static points, moved out to
// the walls any training view saw in slivers, and holding the sources'
// cameras with kLayoutCameraMargin x their median depth to spare.
Layout SourceLayout(const std::vector<cv::Mat>& rgb,
                    const std::vector<cv::Mat>& depth_maps,
                    const std::vector<cv::Mat>& moving,
                    const std::vector<RasterCamera>& cameras,
                    const std::vector<TrainingView>& views) {
  const PointCloud points =
      StaticSourcePoints(rgb, depth_maps, moving, cameras);
  std::vector<Eigen::Vector3f> centres;
  std::vector<double> depths;
  for (std::size_t s = 0; s < cameras.size(); ++s) {
    centres.push_back(cameras[s].Center());
    const cv::Mat& d = depth_maps[s];
    for (int y = 0; y < d.rows; y += kLayoutStride)
      for (int x = 0; x < d.cols; x += kLayoutStride)
        if (d.at<float>(y, x) > 0) depths.push_back(d.at<float>(y, x));
  }
  const float margin = depths.empty()
                           ? 0.0f
                           : static_cast<float>(kLayoutCameraMargin *
                                                UpperMedian(std::move(depths)));
  Layout layout = FitLayout(points, centres);
  FitSliverWalls(PointsBeyond(layout, views), &layout);
  HoldViewpoints(centres, margin, &layout);
  return layout;
}

// Drops the points (and their depths) in known empty space (free_space.h).
// Returns the count dropped.
std::int64_t KeepOutOfSeenFreeSpace(const std::vector<SeenDepth>& frames,
                                    const std::vector<SeenDepth>& expanded,
                                    PointCloud* points,
                                    std::vector<double>* depths) {
  static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float));
  const std::vector<std::uint8_t> empty = InFreeSpace(
      frames, expanded, points->points.front().data(), points->size());
  PointCloud kept;
  std::vector<double> kept_depths;
  for (std::size_t i = 0; i < empty.size(); ++i) {
    if (empty[i]) continue;
    kept.points.push_back(points->points[i]);
    kept.colors.push_back(points->colors[i]);
    kept_depths.push_back((*depths)[i]);
  }
  const auto rejected = static_cast<std::int64_t>(points->size() - kept.size());
  *points = std::move(kept);
  *depths = std::move(kept_depths);
  return rejected;
}

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

void CheckSize(const std::filesystem::path& path, int width, int height,
               const RasterCamera& camera) {
  if (width != camera.width || height != camera.height) {
    throw Error(path.string(), "size", SizeText(width, height),
                "expected " + SizeText(camera.width, camera.height) +
                    ", the size of its camera");
  }
}

// A refined frame (CV_32FC3 RGB) as RunStep wrote it, checked against its
// camera.
cv::Mat ReadRefined(const std::filesystem::path& path,
                    const RasterCamera& camera) {
  const cv::Mat refined = ReadImage(path).mat();
  CheckSize(path, refined.cols, refined.rows, camera);
  return refined;
}

// A refined frame's depth as RunStep wrote it, checked against its camera.
cv::Mat ReadDepth(const std::filesystem::path& path,
                  const RasterCamera& camera) {
  const NpyArray array = ReadNpy(path);
  if (array.shape.size() != 2 || array.shape[0] != camera.height ||
      array.shape[1] != camera.width) {
    throw Error(path.string(), "shape", "",
                "expected " + std::to_string(camera.height) + " x " +
                    std::to_string(camera.width) + ", the size of its camera");
  }
  const std::vector<float> d = array.ToFloats();
  for (float z : d)
    if (!std::isfinite(z))
      throw Error(path.string(), "depth", std::to_string(z), "not finite");
  cv::Mat depth(camera.height, camera.width, CV_32FC1);
  std::copy(d.begin(), d.end(), depth.begin<float>());
  return depth;
}

// The depth `view` is warped with (WarpDepth): z-depth rendered from the
// fit's Gaussians where they are opaque enough to trust (kWarpAlpha),
// 0 elsewhere; with kGiven, the view's own depth wherever it has some.
cv::Mat SourceDepth(SceneEditor* fit, const TrainingView& view,
                    WarpDepth warp_depth, RenderOutput* out) {
  const RasterCamera& camera = view.camera;
  fit->Render(camera, view.time, out);
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0));
  for (std::size_t p = 0; p < out->depth.size(); ++p)
    if (out->alpha[p] >= kWarpAlpha)
      depth.at<float>(static_cast<int>(p)) = out->depth[p];
  if (warp_depth == WarpDepth::kGiven && !view.depth.empty()) {
    const cv::Mat given = MatView(view.depth, camera.height, camera.width);
    given.copyTo(depth, given > 0);
  }
  return depth;
}

// A training view's moving pixels (its dynamic mask) as CV_8UC1, 255 =
// moving.
cv::Mat MovingMask(const TrainingView& view) {
  return MatView(view.dynamic, view.camera.height, view.camera.width) != 0;
}

// The source's moving pixels (CV_8UC1, 255 = moving) forward-warped into
// `target` like the frame itself (same depth, same z-buffer): 255 where a
// landed pixel is mostly moving, 0 elsewhere and in holes.
cv::Mat WarpMoving(const cv::Mat& moving, const cv::Mat& depth,
                   const RasterCamera& source, const RasterCamera& target) {
  cv::Mat share;
  moving.convertTo(share, CV_32F, 1.0 / 255);
  cv::Mat share3;
  cv::merge(std::vector<cv::Mat>{share, share, share}, share3);
  const WarpResult w = ForwardWarp(share3, depth, source, target);
  cv::Mat landed;
  cv::extractChannel(w.rgb, landed, 0);
  return (landed > 0.5f) & (w.mask == 0);
}

// PriorClip::moving is all or none (one mask per frame): a clip some of
// whose sources have no dynamic mask gives the prior none.
void KeepMovingIfEveryFrameHasIt(PriorClip* clip) {
  if (clip->moving.size() != clip->frames.size()) clip->moving.clear();
}

}  // namespace

void ExpansionOptions::Check() const {
  geometry.Check();
  const auto positive = [](double v, const char* name) {
    CheckPositive(v, "expansion options", name);
  };
  positive(every, "every");
  positive(refine_every, "refine_every");
  positive(time_stride, "time_stride");
  positive(new_gaussian_stride, "new_gaussian_stride");
  positive(voxel_pixels, "voxel_pixels");
  if (carve_every < 0) {
    throw Error("expansion options", "carve_every", std::to_string(carve_every),
                "must be zero (only at the steps) or positive");
  }
  CheckNonNegative(refine_weight, "expansion options", "refine_weight");
  if (!(refine_outside_weight >= 0)) {
    throw Error("expansion options", "refine_outside_weight",
                std::to_string(refine_outside_weight),
                "must be zero (the paper's masked loss) or positive");
  }
}

nlohmann::json ExpansionOptions::ToJson() const {
  return {{"directions", geometry.directions},
          {"steps", geometry.steps},
          {"alpha_degrees", geometry.alpha_degrees},
          {"planar", geometry.planar},
          {"every", every},
          {"refine_weight", refine_weight},
          {"refine_outside_weight", refine_outside_weight},
          {"refine_every", refine_every},
          {"time_stride", time_stride},
          {"one_step", one_step},
          {"gaussian_refinement", gaussian_refinement},
          {"new_gaussian_stride", new_gaussian_stride},
          {"voxel_pixels", voxel_pixels},
          {"carve_every", carve_every},
          {"warp_depth", WarpDepthName(warp_depth)}};
}

const char* WarpDepthName(WarpDepth w) {
  return w == WarpDepth::kGiven ? "given" : "rendered";
}

std::vector<int> StepsDueAt(const ExpansionOptions& o, std::int64_t iteration,
                            int iterations) {
  if (iteration <= 0 || iteration % o.every != 0 || iteration >= iterations)
    return {};
  const std::int64_t k = iteration / o.every;
  const std::int64_t expansions = (iterations - 1) / o.every;
  const int steps = o.geometry.steps;
  if (o.one_step) return k == 1 ? std::vector<int>{steps} : std::vector<int>{};
  const auto up_to = [&](std::int64_t j) {
    return static_cast<int>((steps * j + expansions - 1) / expansions);
  };
  std::vector<int> due;
  for (int e = up_to(k - 1) + 1; e <= up_to(k); ++e) due.push_back(e);
  return due;
}

std::int64_t LastExpansionIteration(const ExpansionOptions& o, int iterations) {
  const std::int64_t expansions = (iterations - 1) / o.every;
  if (expansions == 0) return 0;
  return o.one_step ? o.every : expansions * o.every;
}

int LastStepBefore(const ExpansionOptions& o, std::int64_t before,
                   int iterations) {
  int last = 0;
  for (std::int64_t it = o.every; it < before; it += o.every)
    for (int e : StepsDueAt(o, it, iterations)) last = std::max(last, e);
  return last;
}

std::string ExpansionStepReport::Brief() const {
  std::ostringstream s;
  s.precision(3);
  s << "expansion step " << step << " (" << angle_degrees << " deg): " << views
    << " views, holes " << 100 * hole_fraction << "% (chained "
    << 100 * prefilled_fraction << "% of them, cracks " << 100 * crack_fraction
    << "%), " << new_gaussians << " new Gaussians (" << rejected_in_free_space
    << " candidates in seen free space dropped; " << carved
    << " Gaussians there removed), prior " << prior << ", layout "
    << (layout_planes < 0 ? std::string("none")
                          : std::to_string(layout_planes) + " plane faces");
  if (fallbacks > 0) s << " (" << fallbacks << " fallbacks)";
  s << ", " << seconds << " s";
  return s.str();
}

nlohmann::json ExpansionStepReport::ToJson() const {
  return {{"step", step},
          {"angle_degrees", angle_degrees},
          {"views", views},
          {"hole_fraction", hole_fraction},
          {"prefilled_fraction", prefilled_fraction},
          {"crack_fraction", crack_fraction},
          {"rejected_in_free_space", rejected_in_free_space},
          {"carved", carved},
          {"layout_planes", layout_planes},
          {"new_gaussians", new_gaussians},
          {"prior", prior},
          {"fallbacks", fallbacks},
          {"seconds", seconds}};
}

Expansion::Expansion(ExpansionOptions options, std::uint64_t seed,
                     std::filesystem::path out_dir, Prior* prior)
    : options_(std::move(options)),
      seed_(seed),
      out_dir_(std::move(out_dir)),
      prior_(prior) {
  options_.Check();
  if (!prior_) throw Error("expansion", "prior", "null", "a prior is needed");
}

void Expansion::NameViews(const SceneEditor& fit,
                          std::vector<ExpandedView>* views) const {
  const std::size_t ns = sources_.size();
  for (std::size_t k = 0; k < views->size(); ++k)
    (*views)[k].name = fit.views()[sources_[k % ns].view].name;
}

std::filesystem::path Expansion::StepDir(int e) const {
  return out_dir_ / ("step_" + ZeroPadded(e, 2));
}

void Expansion::Prepare(const SceneEditor& fit) {
  if (prepared_) return;
  const std::vector<TrainingView>& views = fit.views();
  if (views.empty())
    throw Error("expansion", "views", "0", "no training views");
  std::vector<std::size_t> order(views.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) {
                     return views[a].time < views[b].time;
                   });
  reference_ = views[order[0]].camera;
  sources_.clear();
  for (std::size_t i = 0; i < order.size();
       i += static_cast<std::size_t>(options_.time_stride)) {
    const TrainingView& v = views[order[i]];
    sources_.push_back({order[i], v.camera, v.time});
  }
  const ExpansionGeometry& g = options_.geometry;
  CheckMemoryFits(
      kExpandedViewBytesPerPixel * g.directions * g.steps * sources_.size() *
          reference_.width * reference_.height,
      "expansion",
      StringPrintf("%d directions x %d steps x %zu source frames of %dx%d "
                   "(--directions, --expansion-steps, --expansion-stride)",
                   g.directions, g.steps, sources_.size(), reference_.width,
                   reference_.height));
  frames_seen_.clear();
  for (const TrainingView& v : views) {
    if (v.depth.empty()) continue;
    const cv::Mat depth = MatView(v.depth, v.camera.height, v.camera.width);
    frames_seen_.push_back(MakeSeenDepth(v.camera, depth));
    frames_seen_.back().clearance = CameraClearance(depth);
  }
  {  // layout_: the sources' training depth, as at the first step
    std::vector<cv::Mat> rgb, depth, moving;
    std::vector<RasterCamera> cameras;
    for (const Source& s : sources_) {
      const TrainingView& v = views[s.view];
      if (v.depth.empty()) continue;
      rgb.push_back(MatView(v.rgb, v.camera.height, v.camera.width, 3));
      depth.push_back(MatView(v.depth, v.camera.height, v.camera.width));
      moving.push_back(v.dynamic.empty() ? cv::Mat() : MovingMask(v));
      cameras.push_back(v.camera);
    }
    if (!cameras.empty())
      layout_ = SourceLayout(rgb, depth, moving, cameras, views);
  }
  const std::filesystem::path frame_path = out_dir_ / "frame.json";
  if (last_step_ > 0) {
    if (!std::filesystem::exists(frame_path)) {
      throw Error(frame_path.string(), "file", "",
                  "missing: the panorama frame of the steps already run is "
                  "needed to go on from them (for pano4d fit: run again "
                  "without --resume)");
    }
    const Json j = ReadJson(frame_path);
    const auto c = GetJson<std::vector<double>>(j, "center", frame_path);
    const auto r = GetJson<std::vector<double>>(j, "r_align", frame_path);
    if (c.size() != 3 || r.size() != 9) {
      throw Error(frame_path.string(), "center/r_align", "",
                  "expected 3 and 9 numbers");
    }
    frame_.center = Eigen::Vector3d(c[0], c[1], c[2]);
    for (int i = 0; i < 9; ++i) frame_.r_align(i / 3, i % 3) = r[i];
  } else {
    const GaussianScene& scene = fit.scene();
    std::vector<Eigen::Vector3f> points;
    for (const GaussianModel* m : {&scene.statics, &scene.dynamics})
      for (std::size_t i = 0; i < m->size(); ++i)
        points.emplace_back(m->means[i * 3], m->means[i * 3 + 1],
                            m->means[i * 3 + 2]);
    std::vector<RasterCamera> cameras;
    for (std::size_t i : order) cameras.push_back(views[i].camera);
    frame_ = MakePanoramaFrame(points, cameras);
    std::vector<double> r(9);
    for (int i = 0; i < 9; ++i) r[i] = frame_.r_align(i / 3, i % 3);
    EnsureDirectory(out_dir_);
    WriteJson(
        frame_path,
        {{"center", {frame_.center.x(), frame_.center.y(), frame_.center.z()}},
         {"r_align", r},
         {"note",
          "panorama frame (DESIGN.md): p~ = R_align^T (p - "
          "center); r_align row-major"}});
  }
  prepared_ = true;
}

ExpansionStepReport Expansion::RunStep(SceneEditor* fit, int e) {
  const auto start = std::chrono::steady_clock::now();
  Prepare(*fit);
  ExpansionStepReport report;
  report.step = e;
  report.angle_degrees = e * options_.geometry.alpha_degrees;
  report.prior = prior_->name();
  const StepSources sources = GatherSources(fit, e);
  report.layout_planes =
      sources.layout.valid
          ? static_cast<int>(std::count(sources.layout.on_plane.begin(),
                                        sources.layout.on_plane.end(), true))
          : -1;
  const bool chain = last_step_ == e - 1 && !previous_.empty();
  const std::filesystem::path dir = StepDir(e);
  std::filesystem::remove_all(dir);
  const int directions = options_.geometry.directions;
  const std::size_t ns = sources_.size();
  std::vector<Refined> current(directions * ns);
  NewPoints points;
  WarpStats warp;
  ProgressBar bar(
      StringPrintf("expansion step %d (%g deg)", e, report.angle_degrees),
      static_cast<std::int64_t>(sources.views.size()), std::cerr,
      ProgressBar::Mode::kAuto, kStepProgressAfterSeconds);
  for (int m = 0; m < directions; ++m) {
    std::vector<cv::Mat> masks;
    PriorClip clip = WarpDirection(sources, e, m, chain, &masks, &warp);
    KeepMovingIfEveryFrameHasIt(&clip);
    const PriorResult filled = prior_->Fill(clip);
    if (filled.prior != prior_->name()) {
      ++report.fallbacks;
      report.prior = prior_->name() + " -> " + filled.prior;
    }
    KeepDirection(fit, sources, m, clip, filled, masks,
                  dir / ("dir_" + std::to_string(m)), &current, &points);
    bar.Add(static_cast<std::int64_t>(ns));
  }
  bar.Finish();
  Json cameras_json = Json::array();
  for (const ExpandedView& v : sources.views) cameras_json.push_back(ToJson(v));
  WriteJson(dir / "cameras.json", {{"step", e},
                                   {"angle_degrees", report.angle_degrees},
                                   {"views", cameras_json}});
  previous_ = std::move(current);
  last_step_ = e;
  const std::size_t count = sources.views.size();
  report.views = static_cast<int>(count);
  report.hole_fraction = count == 0 ? 0.0 : warp.hole_sum / count;
  report.prefilled_fraction =
      warp.holes > 0 ? warp.prefilled / warp.holes : 0.0;
  report.crack_fraction = warp.holes > 0 ? warp.cracks / warp.holes : 0.0;
  if (options_.gaussian_refinement)
    AddStepGaussians(fit, count, &points, &report);
  all_cameras_.insert(all_cameras_.end(), sources.views.begin(),
                      sources.views.end());
  report.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return report;
}

Expansion::StepSources Expansion::GatherSources(SceneEditor* fit, int e) {
  StepSources out;
  std::vector<RasterCamera> source_cameras;
  std::vector<int> times;
  for (const Source& s : sources_) {
    source_cameras.push_back(s.camera);
    times.push_back(s.time);
  }
  out.views = ExpansionViews(options_.geometry, reference_, frame_.center,
                             source_cameras, times, e);
  NameViews(*fit, &out.views);
  // The sources' warp depth (options' warp_depth), fixed for the whole
  // step, and their moving pixels for the prior (empty where a view has no
  // dynamic mask).
  const std::vector<TrainingView>& views = fit->views();
  const std::size_t ns = sources_.size();
  out.rgb.resize(ns);
  out.depth.resize(ns);
  out.moving.resize(ns);
  RenderOutput rendered;
  for (std::size_t s = 0; s < ns; ++s) {
    const TrainingView& v = views[sources_[s].view];
    out.rgb[s] = MatView(v.rgb, v.camera.height, v.camera.width, 3);
    out.depth[s] = SourceDepth(fit, v, options_.warp_depth, &rendered);
    if (!v.dynamic.empty()) out.moving[s] = MovingMask(v);
  }
  out.layout =
      SourceLayout(out.rgb, out.depth, out.moving, source_cameras, views);
  return out;
}

PriorClip Expansion::WarpDirection(const StepSources& sources, int e, int m,
                                   bool chain, std::vector<cv::Mat>* masks,
                                   WarpStats* stats) const {
  const std::size_t ns = sources_.size();
  PriorClip clip;
  clip.name = "step" + ZeroPadded(e, 2) + "_dir" + std::to_string(m);
  masks->assign(ns, cv::Mat());
  for (std::size_t s = 0; s < ns; ++s) {
    const ExpandedView& v = sources.views[m * ns + s];
    WarpResult w = ForwardWarp(sources.rgb[s], sources.depth[s],
                               sources_[s].camera, v.camera);
    if (!sources.moving[s].empty()) {
      clip.moving.push_back(WarpMoving(sources.moving[s], sources.depth[s],
                                       sources_[s].camera, v.camera));
    }
    (*masks)[s] = w.mask.clone();
    const int hole = cv::countNonZero(w.mask);
    stats->hole_sum += static_cast<double>(hole) / w.mask.total();
    stats->holes += hole;
    stats->cracks += static_cast<double>(CountCracks(w.mask));
    if (chain) {
      const Refined& p = previous_[m * ns + s];
      stats->prefilled +=
          FillHoles(ForwardWarp(p.rgb, p.depth, p.camera, v.camera), &w);
    }
    if (sources.layout.valid) {
      cv::Mat layout_depth, layout_rgb;
      RenderLayout(sources.layout, v.camera, &layout_depth, &layout_rgb);
      clip.layout_depth.push_back(layout_depth);
      clip.layout_rgb.push_back(layout_rgb);
    }
    clip.frames.push_back(w.rgb);
    clip.masks.push_back(w.mask);
    clip.depth.push_back(w.depth);
    clip.cameras.push_back(v.camera);
    clip.times.push_back(v.t);
    clip.references.push_back(sources.rgb[s]);
    clip.reference_cameras.push_back(sources_[s].camera);
  }
  return clip;
}

void Expansion::KeepDirection(SceneEditor* fit, const StepSources& sources,
                              int m, const PriorClip& clip,
                              const PriorResult& filled,
                              const std::vector<cv::Mat>& masks,
                              const std::filesystem::path& dir,
                              std::vector<Refined>* current,
                              NewPoints* points) {
  const std::size_t ns = sources_.size();
  RenderOutput out;
  for (std::size_t s = 0; s < ns; ++s) {
    const ExpandedView& v = sources.views[m * ns + s];
    const cv::Mat refined =
        Quantised(Composite(clip.frames[s], filled.frames[s], clip.masks[s]));
    const cv::Mat refined_depth = RefinedDepth(
        clip.depth[s], clip.masks[s],
        filled.depth.empty() ? cv::Mat() : filled.depth[s],
        clip.layout_depth.empty() ? cv::Mat() : clip.layout_depth[s]);
    (*current)[m * ns + s] = {v.camera, refined, refined_depth};
    const std::string& id = v.name;
    WriteImage(dir / "warped" / (id + ".png"),
               Image::FromRgb32f(clip.frames[s].clone()));
    WriteMask(dir / "mask" / (id + ".png"), masks[s]);
    WriteImage(dir / "refined" / (id + ".png"),
               Image::FromRgb32f(refined.clone()));
    WriteNpy(
        dir / "depth" / (id + ".npy"),
        NpyArray::FromFloats({refined_depth.rows, refined_depth.cols},
                             std::vector<float>(refined_depth.begin<float>(),
                                                refined_depth.end<float>())));
    if (!options_.gaussian_refinement) continue;
    fit->Render(v.camera, v.t, &out);
    const RasterCamera& c = v.camera;
    for (int y = 0; y < c.height; y += options_.new_gaussian_stride) {
      for (int x = 0; x < c.width; x += options_.new_gaussian_stride) {
        const std::size_t p = static_cast<std::size_t>(y) * c.width + x;
        const float z = refined_depth.at<float>(y, x);
        if (!masks[s].at<std::uint8_t>(y, x) || out.alpha[p] >= kCoveredAlpha ||
            !(z > 0))
          continue;
        points->cloud.points.push_back(c.Unproject(x + 0.5f, y + 0.5f, z));
        const cv::Vec3f col = refined.at<cv::Vec3f>(y, x);
        points->cloud.colors.emplace_back(col[0], col[1], col[2]);
        points->depths.push_back(z);
      }
    }
    points->focals.push_back(0.5 * (c.fx + c.fy));
    expanded_seen_.push_back(MakeSeenDepth(c, refined_depth, masks[s]));
    StoredView stored{c, v.t, cv::Mat(), masks[s]};
    refined.convertTo(stored.target, CV_8UC3, 255.0);
    views_.push_back(std::move(stored));
  }
}

void Expansion::AddStepGaussians(SceneEditor* fit, std::size_t step_views,
                                 NewPoints* points,
                                 ExpansionStepReport* report) {
  report->carved = Carve(fit);
  if (points->cloud.size() == 0) return;
  // Checked against this step's views.
  const std::vector<SeenDepth> step_seen(
      expanded_seen_.end() - static_cast<std::ptrdiff_t>(step_views),
      expanded_seen_.end());
  report->rejected_in_free_space = KeepOutOfSeenFreeSpace(
      frames_seen_, step_seen, &points->cloud, &points->depths);
  if (points->cloud.size() == 0) return;
  const double voxel = UpperMedian(points->depths) * options_.voxel_pixels /
                       UpperMedian(points->focals);
  PointCloudFilterOptions filter;
  filter.voxel_size = voxel;
  InitOptions init;
  init.sh_degree = fit->scene().statics.sh_degree;
  const PointCloud kept = FilterPointCloud(points->cloud, filter);
  report->new_gaussians =
      fit->AddStaticGaussians(GaussiansFromCloud(kept, voxel, init));
}

Expansion::Shell Expansion::AddLayoutShell(SceneEditor* fit) {
  if (!options_.gaussian_refinement) return {};
  Prepare(*fit);
  Shell shell;
  const Layout& layout = layout_;
  if (!layout.valid) return shell;
  shell.planes = static_cast<int>(
      std::count(layout.on_plane.begin(), layout.on_plane.end(), true));
  for (int face = 0; face < 6; ++face) {
    const int j = face / 2;
    const Eigen::Vector3f& c = layout.colours[face];
    PANO4D_LOG(kDebug) << "layout face " << face << ": axis ("
                       << layout.axes.col(j).transpose() << ") at "
                       << (face % 2 ? layout.hi[j] : layout.lo[j])
                       << (layout.on_plane[face] ? ", plane" : ", no plane")
                       << ", colour (" << c.transpose() << ")";
  }
  const float spacing = ShellSpacing(layout);
  const PointCloud faces = SampleLayoutFaces(layout, spacing);
  const auto unseen = [&](const Eigen::Vector3f& p) {
    const Sight sight = Look(frames_seen_, p);
    return sight == Sight::kUnseen || sight == Sight::kUnknown;
  };
  // Unseen or unknown to every frame. Off the fitted planes, so is every
  // point kShellReach spacings away along the axes: a guessed face there
  // would veil a frame's edge. On a plane the shell is the surface itself.
  const auto keep = [&](const Eigen::Vector3f& centre) {
    if (!unseen(centre)) return false;
    if (layout.PlaneFaceAt(centre, kOnPlaneSpacings * spacing)) return true;
    for (int k = 1; k < 7; ++k) {
      Eigen::Vector3f p = centre;
      p[(k - 1) / 2] += (k % 2 ? 1 : -1) * kShellReach * spacing;
      if (!unseen(p)) return false;
    }
    return true;
  };
  PointCloud kept;
  for (std::size_t i = 0; i < faces.size(); ++i) {
    if (!keep(faces.points[i])) continue;
    kept.points.push_back(faces.points[i]);
    kept.colors.push_back(faces.colors[i]);
  }
  if (kept.size() == 0) return shell;
  InitOptions init;
  init.sh_degree = fit->scene().statics.sh_degree;
  init.initial_opacity = kShellOpacity;
  shell.gaussians =
      fit->AddStaticGaussians(GaussiansFromCloud(kept, spacing, init));
  return shell;
}

std::int64_t Expansion::Carve(SceneEditor* fit) {
  if (views_.empty()) return 0;
  const GaussianModel& statics = fit->scene().statics;
  if (statics.size() == 0) return 0;
  const std::vector<std::uint8_t> empty = InFreeSpace(
      frames_seen_, expanded_seen_, statics.means.data(), statics.size(),
      &layout_, kOnPlaneSpacings * ShellSpacing(layout_));
  std::vector<std::uint8_t> keep(empty.size());
  for (std::size_t i = 0; i < keep.size(); ++i) keep[i] = !empty[i];
  const std::int64_t removed = fit->RemoveStaticGaussians(keep);
  carved_ += removed;
  return removed;
}

const ExtraView* Expansion::ViewFor(std::int64_t iteration) {
  if (views_.empty() || !options_.gaussian_refinement ||
      iteration % options_.refine_every != 0)
    return nullptr;
  const std::size_t i =
      SplitMix64(seed_ ^ static_cast<std::uint64_t>(iteration)) % views_.size();
  const StoredView& v = views_[i];
  buffer_.camera = v.camera;
  buffer_.time = v.time;
  buffer_.weight = options_.refine_weight;
  buffer_.outside_weight = options_.refine_outside_weight;
  buffer_.target.resize(v.target.total() * 3);
  const std::uint8_t* t = v.target.ptr<std::uint8_t>();
  for (std::size_t k = 0; k < buffer_.target.size(); ++k)
    buffer_.target[k] = t[k] / 255.0f;
  buffer_.mask.assign(v.mask.ptr<std::uint8_t>(),
                      v.mask.ptr<std::uint8_t>() + v.mask.total());
  return &buffer_;
}

void Expansion::Reload(const SceneEditor& fit, int last_step) {
  if (last_step <= 0) return;
  last_step_ = last_step;
  Prepare(fit);
  const int directions = options_.geometry.directions;
  previous_.assign(directions * sources_.size(), Refined());
  for (int e = options_.one_step ? last_step : 1; e <= last_step; ++e) {
    const std::filesystem::path cameras_path = StepDir(e) / "cameras.json";
    if (!std::filesystem::exists(cameras_path)) {
      throw Error(cameras_path.string(), "file", "",
                  "missing: the expansion products of step " +
                      std::to_string(e) +
                      " are needed to go on from it (for pano4d fit: run "
                      "again without --resume)");
    }
    std::vector<ExpandedView> cams = ExpansionViews(
        options_.geometry, reference_, frame_.center,
        [&] {
          std::vector<RasterCamera> c;
          for (const Source& s : sources_) c.push_back(s.camera);
          return c;
        }(),
        [&] {
          std::vector<int> t;
          for (const Source& s : sources_) t.push_back(s.time);
          return t;
        }(),
        e);
    NameViews(fit, &cams);
    for (std::size_t k = 0; k < cams.size(); ++k) {
      const ExpandedView& v = cams[k];
      const std::filesystem::path dm =
          StepDir(e) / ("dir_" + std::to_string(v.m));
      const std::string& id = v.name;
      const cv::Mat refined =
          ReadRefined(dm / "refined" / (id + ".png"), v.camera);
      const bool last = e == last_step;
      if (!options_.gaussian_refinement && !last) continue;
      const cv::Mat depth = ReadDepth(dm / "depth" / (id + ".npy"), v.camera);
      if (last) previous_[k] = {v.camera, refined.clone(), depth};
      if (!options_.gaussian_refinement) continue;
      const std::filesystem::path mask_path = dm / "mask" / (id + ".png");
      const cv::Mat mask = ReadMask(mask_path);
      CheckSize(mask_path, mask.cols, mask.rows, v.camera);
      expanded_seen_.push_back(MakeSeenDepth(v.camera, depth, mask));
      StoredView stored{v.camera, v.t, cv::Mat(), mask};
      refined.convertTo(stored.target, CV_8UC3, 255.0);
      views_.push_back(std::move(stored));
    }
    all_cameras_.insert(all_cameras_.end(), cams.begin(), cams.end());
  }
}

std::vector<cv::Mat> Expansion::PanoramicViews(
    SceneEditor* fit, const std::string& name,
    const std::vector<RasterCamera>& cameras, const std::vector<int>& times,
    std::string* note) {
  if (last_step_ == 0 || all_cameras_.empty()) {
    throw Error("expansion", "steps", "0",
                "no expansion step has run: there is no panoramic "
                "representation to render");
  }
  if (cameras.size() != times.size()) {
    throw Error(
        "panoramic views", "times", std::to_string(times.size()),
        "expected one per camera (" + std::to_string(cameras.size()) + ")");
  }
  const std::vector<TrainingView>& views = fit->views();
  const auto nearest = [](const auto& items, int time, auto time_of) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < items.size(); ++i)
      if (std::abs(time_of(items[i]) - time) <
          std::abs(time_of(items[best]) - time))
        best = i;
    return best;
  };
  // The refined frames of one source over every step, loaded when a target
  // first needs them (targets of one trajectory mostly share a source).
  struct Loaded {
    RasterCamera camera;
    cv::Mat rgb, depth;
  };
  std::size_t loaded_source = sources_.size();
  std::vector<Loaded> loaded;
  RenderOutput out;
  PriorClip clip;
  clip.name = name;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const RasterCamera& target = cameras[k];
    const TrainingView& v = views[nearest(
        views, times[k], [](const TrainingView& t) { return t.time; })];
    const cv::Mat rgb = MatView(v.rgb, v.camera.height, v.camera.width, 3);
    const cv::Mat depth = SourceDepth(fit, v, options_.warp_depth, &out);
    WarpResult w = ForwardWarp(rgb, depth, v.camera, target);
    if (!v.dynamic.empty())
      clip.moving.push_back(WarpMoving(MovingMask(v), depth, v.camera, target));
    const std::size_t s =
        nearest(sources_, times[k], [](const Source& x) { return x.time; });
    if (s != loaded_source) {
      loaded.clear();
      const std::string& id = views[sources_[s].view].name;
      for (const ExpandedView& c : all_cameras_) {
        if (c.name != id) continue;
        const std::filesystem::path dm =
            StepDir(c.e) / ("dir_" + std::to_string(c.m));
        loaded.push_back({c.camera,
                          ReadRefined(dm / "refined" / (id + ".png"), c.camera),
                          ReadDepth(dm / "depth" / (id + ".npy"), c.camera)});
      }
      loaded_source = s;
    }
    for (const Loaded& l : loaded) {
      if (cv::countNonZero(w.mask) == 0) break;
      FillHoles(ForwardWarp(l.rgb, l.depth, l.camera, target), &w);
    }
    clip.frames.push_back(w.rgb);
    clip.masks.push_back(w.mask);
    clip.depth.push_back(w.depth);
    clip.cameras.push_back(target);
    clip.times.push_back(times[k]);
    clip.references.push_back(rgb.clone());
    clip.reference_cameras.push_back(v.camera);
  }
  KeepMovingIfEveryFrameHasIt(&clip);
  const PriorResult filled = prior_->Fill(clip);
  if (note) *note = filled.note;
  std::vector<cv::Mat> result(cameras.size());
  for (std::size_t k = 0; k < cameras.size(); ++k)
    result[k] = Composite(clip.frames[k], filled.frames[k], clip.masks[k]);
  return result;
}

}  // namespace pano4d
