#include "src/gs/init.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <optional>
#include <sstream>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/log.h"
#include "src/core/median.h"
#include "src/core/option_checks.h"
#include "src/core/timer.h"
#include "src/geometry/inpaint.h"
#include "src/render/sh.h"

namespace pano4d {
namespace {

// Initial scales are clamped to [kMinScaleVoxels, kMaxScaleVoxels] voxels:
// duplicate points give a zero neighbour distance (log -inf), and isolated
// points survivors of outlier removal would start as huge blobs.
constexpr double kMinScaleVoxels = 0.25;
constexpr double kMaxScaleVoxels = 8.0;
// Nearest tracks that vote for a dynamic Gaussian's initial basis weights.
constexpr int kVotingTracks = 8;
// Added to each basis' share of the votes before the log: every basis keeps
// some weight, so its gradient never vanishes.
constexpr float kVoteFloor = 1e-3f;
// Procrustes inliers: residual within this many times the median.
constexpr double kInlierFactor = 3.0;
// Pixels around a hole that inpainting draws from.
constexpr double kInpaintRadius = 5.0;
// A moving pixel takes its object's local half-width as the largest
// distance to the mask's edge within this many pixels: wide enough to
// reach the middle of the small scene's objects (6-12 pixels across at
// 240 x 180), narrow enough that a far-away object of the same mask does
// not lend its width.
constexpr int kHalfWidthWindow = 15;

// Depth under a continuous pixel position (nearest pixel); 0 outside.
float DepthAt(const std::vector<float>& depth, const RasterCamera& camera,
              const Eigen::Vector2f& p) {
  const int x = static_cast<int>(std::floor(p.x()));
  const int y = static_cast<int>(std::floor(p.y()));
  if (x < 0 || y < 0 || x >= camera.width || y >= camera.height) return 0.0f;
  return depth[static_cast<std::size_t>(y) * camera.width + x];
}

// The view's depth with its moving pixels that have none (stereo cannot
// match an object that moved between the frames) filled by inpainting
// (OpenCV Telea) from the depth around them: a rough start for the dynamic
// Gaussians, which the fit then moves. Other pixels are left as they are.
std::vector<float> DepthForMotion(const TrainingView& v) {
  std::vector<float> out = v.depth;
  if (v.depth.empty() || v.dynamic.empty()) return out;
  const int w = v.camera.width, h = v.camera.height;
  bool missing = false;
  for (std::size_t p = 0; p < out.size() && !missing; ++p)
    missing = v.dynamic[p] && !(out[p] > 0);
  if (!missing) return out;
  cv::Mat depth(h, w, CV_32F, out.data());
  cv::Mat holes = depth <= 0;
  if (cv::countNonZero(holes) == static_cast<int>(depth.total())) return out;
  double max_depth = 0;
  cv::minMaxLoc(depth, nullptr, &max_depth);
  const cv::Mat filled = InpaintTelea(depth, holes, max_depth, kInpaintRadius);
  for (std::size_t p = 0; p < out.size(); ++p) {
    if (v.dynamic[p] && !(out[p] > 0))
      out[p] =
          filled.at<float>(static_cast<int>(p / w), static_cast<int>(p % w));
  }
  return out;
}

// The length, in pixels, of the chord that a round cross-section of the
// moving mask's local width has behind each of its pixels (0 elsewhere):
// 2 sqrt(2 R e - e^2) for a pixel e from the mask's edge, R the largest
// such distance within kHalfWidthWindow (the half-width). For an object
// whose cross-section is round this is its depth extent behind the
// visible surface, which one camera never sees.
cv::Mat ChordPixels(const TrainingView& v) {
  const int w = v.camera.width, h = v.camera.height;
  const cv::Mat dynamic = MatView(v.dynamic, h, w);
  cv::Mat edge_distance, half_width;
  cv::distanceTransform(dynamic != 0, edge_distance, cv::DIST_L2,
                        cv::DIST_MASK_5);
  cv::dilate(edge_distance, half_width,
             cv::getStructuringElement(
                 cv::MORPH_ELLIPSE,
                 cv::Size(2 * kHalfWidthWindow + 1, 2 * kHalfWidthWindow + 1)));
  cv::Mat chord(h, w, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const double e = edge_distance.at<float>(y, x);
      const double r = half_width.at<float>(y, x);  // >= e: a dilation
      chord.at<float>(y, x) =
          static_cast<float>(2.0 * std::sqrt(std::max(0.0, e * (2 * r - e))));
    }
  }
  return chord;
}

// Keeps every k-th point so that at most `max` remain (deterministic).
PointCloud Thin(const PointCloud& cloud, std::int64_t max) {
  if (static_cast<std::int64_t>(cloud.size()) <= max) return cloud;
  PointCloud out;
  const double step = static_cast<double>(cloud.size()) / max;
  for (std::int64_t i = 0; i < max; ++i) {
    const std::size_t j = static_cast<std::size_t>(i * step);
    out.points.push_back(cloud.points[j]);
    out.colors.push_back(cloud.colors[j]);
  }
  return out;
}

// Tracks of `seeds` from the canonical time: along the views' own flow
// (learned priors, TrainingView::flows) where they carry it between
// neighbouring times, else along DIS flow computed on `frames`.
Tracks2D ChainTracksAlongViews(const std::vector<TrainingView>& views,
                               const std::vector<const TrainingView*>& by_time,
                               const std::vector<cv::Mat>& frames,
                               int canonical,
                               const std::vector<Eigen::Vector2f>& seeds,
                               const TrackOptions& options,
                               std::string* source) {
  const int num_times = static_cast<int>(by_time.size());
  const cv::Size size = frames[canonical].size();
  // The given flow from the view at time `from` to the view at `to`.
  const auto link = [&](int from, int to) -> std::optional<FlowLink> {
    const TrainingView* a = by_time[from];
    if (!a || a->camera.width != size.width || a->camera.height != size.height)
      return std::nullopt;
    for (const TrainingView::Flow& f : a->flows) {
      if (views[f.view].time != to) continue;
      FlowLink l;
      l.from = from;
      l.to = to;
      l.forward = MatView(f.flow, size.height, size.width, 2);
      l.valid = MatView(f.valid, size.height, size.width);
      return l;
    }
    return std::nullopt;
  };
  std::vector<FlowLink> links;
  for (int t = canonical; t + 1 < num_times; ++t)
    if (auto l = link(t, t + 1)) links.push_back(*l);
  for (int t = canonical; t - 1 >= 0; --t)
    if (auto l = link(t, t - 1)) links.push_back(*l);
  if (links.empty()) {
    *source = "DIS";
    return ChainFlowTracks(frames, canonical, seeds, options);
  }
  *source = "priors";
  return ChainTracks(num_times, canonical, seeds, links, options);
}

}  // namespace

GaussianModel GaussiansFromCloud(const PointCloud& cloud, double voxel,
                                 const InitOptions& o) {
  GaussianModel m;
  m.sh_degree = o.sh_degree;
  m.Resize(cloud.size());
  if (cloud.size() == 0) return m;
  const std::vector<float> distance = MeanNeighbourDistance(cloud, 3);
  const float opacity = InverseSigmoid(static_cast<float>(o.initial_opacity));
  const int k = m.sh_coefficients();
  std::fill(m.sh.begin(), m.sh.end(), 0.0f);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    for (int c = 0; c < 3; ++c) m.means[i * 3 + c] = cloud.points[i][c];
    const double d =
        std::clamp(static_cast<double>(distance[i]), kMinScaleVoxels * voxel,
                   kMaxScaleVoxels * voxel);
    for (int c = 0; c < 3; ++c)
      m.log_scales[i * 3 + c] = static_cast<float>(std::log(d));
    m.quats[i * 4] = 1;
    m.quats[i * 4 + 1] = m.quats[i * 4 + 2] = m.quats[i * 4 + 3] = 0;
    m.opacities[i] = opacity;
    for (int c = 0; c < 3; ++c)
      m.sh[(i * k) * 3 + c] =
          (cloud.colors[i][c] - 0.5f) / static_cast<float>(kShC0);
  }
  return m;
}

void InitOptions::Check() const {
  const auto positive = [](double v, const char* name) {
    CheckPositive(v, "init options", name);
  };
  positive(pixel_stride, "pixel_stride");
  positive(voxel_pixels, "voxel_pixels");
  positive(static_cast<double>(max_static), "max_static");
  positive(static_cast<double>(max_dynamic), "max_dynamic");
  CheckNonNegative(num_bases, "init options", "num_bases");
  CheckNonNegative(dynamic_thickness, "init options", "dynamic_thickness");
  positive(dynamic_layers, "dynamic_layers");
  if (dynamic_layers > kMaxDynamicLayers) {
    throw Error("init options", "dynamic_layers",
                std::to_string(dynamic_layers),
                "must be at most " + std::to_string(kMaxDynamicLayers));
  }
  positive(track_stride, "track_stride");
  positive(min_tracks_per_fit, "min_tracks_per_fit");
  if (!(initial_opacity > 0 && initial_opacity < 1)) {
    throw Error("init options", "initial_opacity",
                std::to_string(initial_opacity), "must be in (0, 1)");
  }
  if (sh_degree < 0 || sh_degree > 3) {
    throw Error("init options", "sh_degree", std::to_string(sh_degree),
                "must be 0..3");
  }
  filter.Check();
  tracks.Check();
}

nlohmann::json InitOptions::ToJson() const {
  return {{"pixel_stride", pixel_stride},
          {"voxel_pixels", voxel_pixels},
          {"filter",
           {{"neighbours", filter.neighbours},
            {"std_ratio", filter.std_ratio},
            {"voxel_size", filter.voxel_size}}},
          {"max_static", max_static},
          {"max_dynamic", max_dynamic},
          {"num_bases", num_bases},
          {"dynamic_thickness", dynamic_thickness},
          {"dynamic_layers", dynamic_layers},
          {"track_stride", track_stride},
          {"tracks", {{"consistency_threshold", tracks.consistency_threshold}}},
          {"min_tracks_per_fit", min_tracks_per_fit},
          {"initial_opacity", initial_opacity},
          {"sh_degree", sh_degree}};
}

nlohmann::json InitReport::ToJson() const {
  return {{"static_points_raw", static_points_raw},
          {"static_points", static_points},
          {"dynamic_points_raw", dynamic_points_raw},
          {"dynamic_points", dynamic_points},
          {"tracks", tracks},
          {"track_coverage", track_coverage},
          {"track_flow", track_flow},
          {"num_bases", num_bases},
          {"canonical_time", canonical_time},
          {"voxel_size", voxel_size},
          {"seconds", seconds}};
}

std::string InitReport::Brief() const {
  std::ostringstream s;
  s << "init: " << static_points << " static Gaussians (of "
    << static_points_raw << " points), " << dynamic_points << " dynamic (of "
    << dynamic_points_raw << "), " << num_bases << " motion bases from "
    << tracks << " tracks along " << track_flow << " flow (coverage "
    << static_cast<int>(track_coverage * 100 + 0.5) << "%), canonical time "
    << canonical_time << ", voxel " << voxel_size << ", " << seconds << " s";
  return s.str();
}

namespace {

// The voxel of the point cloud filter: voxel_pixels pixels of the median
// focal length at the median depth. Throws pano4d::Error when no view has
// depth.
double VoxelSize(const std::vector<TrainingView>& views, const InitOptions& o) {
  std::vector<double> depths, focals;
  for (const TrainingView& v : views) {
    if (v.depth.empty()) {
      PANO4D_LOG(kWarning) << "init: view " << v.name
                           << " has no depth; it adds no Gaussians";
      continue;
    }
    for (std::size_t p = 0; p < v.depth.size(); p += 97)
      if (v.depth[p] > 0) depths.push_back(v.depth[p]);
    focals.push_back(0.5 * (v.camera.fx + v.camera.fy));
  }
  if (depths.empty()) {
    throw Error("init", "depth", "",
                "no training view has depth; run "
                "`pano4d depth` first");
  }
  return UpperMedian(depths) * o.voxel_pixels / UpperMedian(focals);
}

// Whether any view with depth has moving pixels (and motion is asked for).
bool AnyDynamic(const std::vector<TrainingView>& views, const InitOptions& o) {
  bool any = false;
  for (const TrainingView& v : views) {
    if (o.num_bases == 0 || v.depth.empty()) continue;
    for (std::uint8_t d : v.dynamic) any |= d != 0;
  }
  return any;
}

// The canonical time: the middle of the dynamic content's time range.
int CanonicalTime(const std::vector<TrainingView>& views, int num_times,
                  bool any_dynamic) {
  int canonical = num_times / 2;
  if (any_dynamic) {
    int best = -1;
    for (const TrainingView& v : views) {
      if (v.depth.empty() || v.dynamic.empty()) continue;
      if (best < 0 ||
          std::abs(v.time - num_times / 2) < std::abs(best - num_times / 2))
        best = v.time;
    }
    canonical = best;
  }
  return std::clamp(canonical, 0, num_times - 1);
}

// Every view's static pixels on the pixel_stride grid, and the canonical
// time's moving pixels, each with dynamic_layers more points inside the
// object along its ray, as points in the colour of their pixel.
void UnprojectViews(const std::vector<TrainingView>& views,
                    const std::vector<std::vector<float>>& motion_depth,
                    int canonical, bool any_dynamic, const InitOptions& o,
                    PointCloud* statics, PointCloud* dynamics) {
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    const TrainingView& v = views[vi];
    if (v.depth.empty()) continue;
    const int w = v.camera.width, h = v.camera.height;
    const bool is_canonical = v.time == canonical;
    const cv::Mat chord = is_canonical && any_dynamic && !v.dynamic.empty() &&
                                  o.dynamic_thickness > 0
                              ? ChordPixels(v)
                              : cv::Mat();
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * w + x;
        const bool dynamic = any_dynamic && !v.dynamic.empty() && v.dynamic[p];
        const float z = dynamic ? motion_depth[vi][p] : v.depth[p];
        if (!(z > 0)) continue;
        const bool on_grid = x % o.pixel_stride == 0 && y % o.pixel_stride == 0;
        if (dynamic && !is_canonical) continue;
        if (!dynamic && !on_grid) continue;
        PointCloud& cloud = dynamic ? *dynamics : *statics;
        cloud.points.push_back(v.camera.Unproject(x + 0.5f, y + 0.5f, z));
        cloud.colors.emplace_back(v.rgb[p * 3], v.rgb[p * 3 + 1],
                                  v.rgb[p * 3 + 2]);
        if (!dynamic || chord.empty()) continue;
        // The object's inside, along the same ray, in the pixel's colour.
        const float depth_extent = static_cast<float>(
            o.dynamic_thickness * chord.at<float>(y, x) * z / v.camera.fx);
        const Eigen::Vector3f colour = cloud.colors.back();
        for (int k = 1; k <= o.dynamic_layers; ++k) {
          cloud.points.push_back(v.camera.Unproject(
              x + 0.5f, y + 0.5f,
              z + depth_extent * static_cast<float>(k) / o.dynamic_layers));
          cloud.colors.push_back(colour);
        }
      }
    }
  }
}

// The views by time: the first of each time, and at the canonical time the
// first with depth and moving pixels (the tracks' reference), with the
// depth the tracks are lifted with.
struct ViewsByTime {
  const TrainingView* reference = nullptr;
  std::vector<const TrainingView*> view;
  std::vector<const std::vector<float>*> depth;
};

ViewsByTime IndexByTime(const std::vector<TrainingView>& views,
                        const std::vector<std::vector<float>>& motion_depth,
                        int num_times, int canonical) {
  ViewsByTime index;
  index.view.assign(num_times, nullptr);
  index.depth.assign(num_times, nullptr);
  for (std::size_t vi = 0; vi < views.size(); ++vi) {
    const TrainingView& v = views[vi];
    if (!index.view[v.time]) {
      index.view[v.time] = &v;
      index.depth[v.time] = &motion_depth[vi];
    }
    if (v.time == canonical && !v.depth.empty() && !v.dynamic.empty() &&
        !index.reference) {
      index.reference = &v;
      index.depth[canonical] = &motion_depth[vi];
    }
  }
  index.view[canonical] = index.reference;
  return index;
}

// 2D tracks through the canonical frame's moving pixels with depth: the
// tracker's (`given`) where it has at least kMinGivenTracks of them, else
// chained along the views' optical flow from seeds every track_stride
// pixels.
Tracks2D CanonicalTracks(const std::vector<TrainingView>& views,
                         const ViewsByTime& index, int num_times, int canonical,
                         const InitOptions& o, const Tracks2D* given,
                         std::string* track_flow) {
  const TrainingView* ref = index.reference;
  const std::vector<float>& depth = *index.depth[canonical];
  const int w = ref->camera.width, h = ref->camera.height;
  Tracks2D tracks;
  if (given && given->num_times == num_times) {
    tracks.num_times = num_times;
    tracks.reference_time = canonical;
    for (std::size_t k = 0; k < given->size(); ++k) {
      if (!given->is_valid(k, canonical)) continue;
      const Eigen::Vector2f& p = given->pixel(k, canonical);
      const int x = static_cast<int>(std::floor(p.x()));
      const int y = static_cast<int>(std::floor(p.y()));
      if (x < 0 || y < 0 || x >= w || y >= h) continue;
      const std::size_t i = static_cast<std::size_t>(y) * w + x;
      if (!ref->dynamic[i] || !(depth[i] > 0)) continue;
      for (int t = 0; t < num_times; ++t) {
        tracks.pixels.push_back(given->pixel(k, t));
        tracks.valid.push_back(given->valid[k * num_times + t]);
      }
    }
    *track_flow = "tracker";
  }
  if (static_cast<int>(tracks.size()) >= kMinGivenTracks) return tracks;
  std::vector<cv::Mat> frames(num_times);
  for (int t = 0; t < num_times; ++t) {
    const TrainingView* v = index.view[t];
    if (!v || v->camera.width != w || v->camera.height != h) continue;
    frames[t] = MatView(v->rgb, v->camera.height, v->camera.width, 3);
  }
  std::vector<Eigen::Vector2f> seeds;
  for (int y = 0; y < h; y += o.track_stride)
    for (int x = 0; x < w; x += o.track_stride)
      if (ref->dynamic[static_cast<std::size_t>(y) * w + x] &&
          depth[static_cast<std::size_t>(y) * w + x] > 0)
        seeds.emplace_back(x + 0.5f, y + 0.5f);
  return ChainTracksAlongViews(views, index.view, frames, canonical, seeds,
                               o.tracks, track_flow);
}

// The tracks lifted to 3D: X(t) for every valid (track, time) with depth.
struct LiftedTracks {
  std::size_t count = 0;
  int num_times = 0;
  std::vector<Eigen::Vector3f> points;  // count x num_times
  std::vector<std::uint8_t> ok;         // count x num_times
  std::int64_t valid = 0;
  const Eigen::Vector3f& at(std::size_t i, int t) const {
    return points[i * num_times + t];
  }
  bool has(std::size_t i, int t) const { return ok[i * num_times + t]; }
};

LiftedTracks Lift(const Tracks2D& tracks, const ViewsByTime& index,
                  int num_times) {
  LiftedTracks l;
  l.count = tracks.size();
  l.num_times = num_times;
  l.points.assign(l.count * num_times, Eigen::Vector3f::Zero());
  l.ok.assign(l.count * num_times, 0);
  for (std::size_t i = 0; i < l.count; ++i) {
    for (int t = 0; t < num_times; ++t) {
      if (!tracks.is_valid(i, t) || !index.view[t]) continue;
      const Eigen::Vector2f& p = tracks.pixel(i, t);
      if (index.depth[t]->empty()) continue;
      const float z = DepthAt(*index.depth[t], index.view[t]->camera, p);
      if (!(z > 0)) continue;
      l.points[i * num_times + t] =
          index.view[t]->camera.Unproject(p.x(), p.y(), z);
      l.ok[i * num_times + t] = 1;
      ++l.valid;
    }
  }
  return l;
}

// k-means on displacement trajectories X(t) - X(canonical), gaps filled
// from the nearest valid time: each track's cluster.
std::vector<int> ClusterTrajectories(const LiftedTracks& l, int k,
                                     int canonical, std::uint64_t seed) {
  const std::size_t n = l.count;
  const int num_times = l.num_times;
  std::vector<int> labels(n, 0);
  if (n < 2 || k <= 1) return labels;
  cv::Mat features(static_cast<int>(n), num_times * 3, CV_32F);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f origin = l.at(i, canonical);
    for (int t = 0; t < num_times; ++t) {
      int nearest = canonical;
      for (int d = 0; d < num_times; ++d) {
        if (t - d >= 0 && l.has(i, t - d)) {
          nearest = t - d;
          break;
        }
        if (t + d < num_times && l.has(i, t + d)) {
          nearest = t + d;
          break;
        }
      }
      const Eigen::Vector3f disp = l.at(i, nearest) - origin;
      for (int c = 0; c < 3; ++c)
        features.at<float>(static_cast<int>(i), t * 3 + c) = disp[c];
    }
  }
  cv::Mat label_mat, centres;
  cv::theRNG().state = seed + 1;  // cv::kmeans draws from OpenCV's RNG
  cv::kmeans(features, k, label_mat,
             cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                              50, 1e-6),
             3, cv::KMEANS_PP_CENTERS, centres);
  for (std::size_t i = 0; i < n; ++i)
    labels[i] = label_mat.at<int>(static_cast<int>(i));
  return labels;
}

// The rigid motion from the canonical time to t of the `members` tracks
// (Procrustes, robust by one refit on the inliers); nullopt when it is not
// finite.
std::optional<Eigen::Matrix4d> FitRigidMotion(const LiftedTracks& l,
                                              std::vector<std::size_t> members,
                                              int canonical, int t,
                                              const InitOptions& o) {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3Xd src(3, members.size()), dst(3, members.size());
    for (std::size_t j = 0; j < members.size(); ++j) {
      src.col(j) = l.at(members[j], canonical).cast<double>();
      dst.col(j) = l.at(members[j], t).cast<double>();
    }
    transform = Eigen::umeyama(src, dst, false);
    if (pass == 1) break;
    std::vector<double> residual(members.size());
    for (std::size_t j = 0; j < members.size(); ++j)
      residual[j] = (transform.topLeftCorner<3, 3>() * src.col(j) +
                     transform.topRightCorner<3, 1>() - dst.col(j))
                        .norm();
    const double limit = kInlierFactor * UpperMedian(residual) + 1e-12;
    std::vector<std::size_t> inliers;
    for (std::size_t j = 0; j < members.size(); ++j)
      if (residual[j] <= limit) inliers.push_back(members[j]);
    if (static_cast<int>(inliers.size()) < o.min_tracks_per_fit) break;
    members.swap(inliers);
  }
  if (!transform.allFinite()) return std::nullopt;
  return transform;
}

// One rigid motion per cluster and time; times without enough tracks copy
// the nearest fitted time.
void FitBases(const LiftedTracks& l, const std::vector<int>& labels, int k,
              int canonical, const InitOptions& o, MotionBases* bases) {
  const int num_times = l.num_times;
  bases->Reset(k, num_times);
  for (int c = 0; c < k; ++c) {
    std::vector<std::uint8_t> fitted(num_times, 0);
    fitted[canonical] = 1;  // the identity, by definition of canonical
    for (int t = 0; t < num_times; ++t) {
      if (t == canonical) continue;
      std::vector<std::size_t> members;
      for (std::size_t i = 0; i < l.count; ++i)
        if (labels[i] == c && l.has(i, t) && l.has(i, canonical))
          members.push_back(i);
      if (static_cast<int>(members.size()) < o.min_tracks_per_fit) continue;
      const std::optional<Eigen::Matrix4d> transform =
          FitRigidMotion(l, std::move(members), canonical, t, o);
      if (!transform) continue;
      Eigen::Quaterniond q(Eigen::Matrix3d(transform->topLeftCorner<3, 3>()));
      if (q.w() < 0) q.coeffs() *= -1;  // the identity's hemisphere
      float* r = bases->rotation(c, t);
      r[0] = static_cast<float>(q.w());
      r[1] = static_cast<float>(q.x());
      r[2] = static_cast<float>(q.y());
      r[3] = static_cast<float>(q.z());
      float* tr = bases->translation(c, t);
      for (int j = 0; j < 3; ++j)
        tr[j] = static_cast<float>((*transform)(j, 3));
      fitted[t] = 1;
    }
    for (int t = 0; t < num_times; ++t) {
      if (fitted[t]) continue;
      for (int d = 1; d < num_times; ++d) {
        const int s = t - d >= 0 && fitted[t - d]          ? t - d
                      : t + d < num_times && fitted[t + d] ? t + d
                                                           : -1;
        if (s < 0) continue;
        std::copy_n(bases->rotation(c, s), 4, bases->rotation(c, t));
        std::copy_n(bases->translation(c, s), 3, bases->translation(c, t));
        break;
      }
    }
  }
}

// Each dynamic Gaussian's basis weights: the clusters of the kVotingTracks
// nearest tracks at the canonical time.
void VoteWeights(const LiftedTracks& l, const std::vector<int>& labels, int k,
                 int canonical, GaussianScene* scene) {
  const std::size_t nd = scene->dynamics.size();
  scene->logits.assign(nd * k, 0.0f);
  std::vector<std::size_t> anchored;
  for (std::size_t i = 0; i < l.count; ++i)
    if (l.has(i, canonical)) anchored.push_back(i);
  if (anchored.empty() || k <= 1) return;
  const std::vector<float>& means = scene->dynamics.means;
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t g = 0; g < static_cast<std::ptrdiff_t>(nd); ++g) {
    const Eigen::Vector3f mu(means[g * 3], means[g * 3 + 1], means[g * 3 + 2]);
    std::vector<std::pair<float, int>> nearest;
    nearest.reserve(anchored.size());
    for (std::size_t i : anchored)
      nearest.push_back({(l.at(i, canonical) - mu).squaredNorm(), labels[i]});
    const std::size_t m = std::min<std::size_t>(kVotingTracks, nearest.size());
    std::partial_sort(nearest.begin(), nearest.begin() + m, nearest.end());
    std::vector<float> share(k, 0.0f);
    for (std::size_t j = 0; j < m; ++j) share[nearest[j].second] += 1.0f / m;
    for (int c = 0; c < k; ++c)
      scene->logits[g * k + c] = std::log(share[c] + kVoteFloor);
  }
}

}  // namespace

GaussianScene InitializeScene(const std::vector<TrainingView>& views,
                              int num_times, const InitOptions& o,
                              std::uint64_t seed, InitReport* report_out,
                              const Tracks2D* given) {
  o.Check();
  const Timer timer;
  InitReport report;
  const auto finish = [&](GaussianScene scene) {
    report.seconds = timer.WallSeconds();
    if (report_out) *report_out = report;
    return scene;
  };
  if (views.empty()) throw Error("init", "views", "0", "no training views");
  const double voxel = VoxelSize(views, o);
  report.voxel_size = voxel;
  const bool any_dynamic = AnyDynamic(views, o);
  const int canonical = CanonicalTime(views, num_times, any_dynamic);
  report.canonical_time = canonical;

  // Points from the depth maps, filtered and thinned.
  std::vector<std::vector<float>> motion_depth(views.size());
  if (any_dynamic) {
    for (std::size_t i = 0; i < views.size(); ++i)
      motion_depth[i] = DepthForMotion(views[i]);
  }
  PointCloud statics, dynamics;
  UnprojectViews(views, motion_depth, canonical, any_dynamic, o, &statics,
                 &dynamics);
  report.static_points_raw = static_cast<std::int64_t>(statics.size());
  report.dynamic_points_raw = static_cast<std::int64_t>(dynamics.size());
  PointCloudFilterOptions filter = o.filter;
  filter.voxel_size = voxel;
  if (statics.size() > 0)
    statics = Thin(FilterPointCloud(statics, filter), o.max_static);
  if (dynamics.size() > 0)
    dynamics = Thin(FilterPointCloud(dynamics, filter), o.max_dynamic);
  report.static_points = static_cast<std::int64_t>(statics.size());
  report.dynamic_points = static_cast<std::int64_t>(dynamics.size());

  GaussianScene scene;
  scene.num_times = num_times;
  scene.canonical_time = canonical;
  scene.statics = GaussiansFromCloud(statics, voxel, o);
  scene.dynamics = GaussiansFromCloud(dynamics, voxel, o);
  scene.dynamics.sh_degree = o.sh_degree;
  if (dynamics.size() == 0) return finish(std::move(scene));

  // The motion bases from tracks of the canonical frame's moving pixels.
  const ViewsByTime index =
      IndexByTime(views, motion_depth, num_times, canonical);
  const Tracks2D tracks = CanonicalTracks(views, index, num_times, canonical, o,
                                          given, &report.track_flow);
  const LiftedTracks lifted = Lift(tracks, index, num_times);
  const std::size_t n = lifted.count;
  report.tracks = static_cast<std::int64_t>(n);
  report.track_coverage =
      n == 0 ? 0.0 : static_cast<double>(lifted.valid) / (n * num_times);
  const int k =
      std::max(1, std::min<int>(o.num_bases, static_cast<int>(n) / 3));
  const std::vector<int> labels =
      ClusterTrajectories(lifted, k, canonical, seed);
  FitBases(lifted, labels, k, canonical, o, &scene.bases);
  VoteWeights(lifted, labels, k, canonical, &scene);
  report.num_bases = k;
  return finish(std::move(scene));
}

}  // namespace pano4d
