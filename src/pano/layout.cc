#include "src/pano/layout.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>

namespace pano4d {
namespace {

// RANSAC's inlier band, as a share of the cloud's median distance to its
// median point: wide enough for rendered depth's noise on a wall, narrow
// enough that a box standing on the floor is not part of the floor.
constexpr double kPlaneTolerance = 0.03;
// A plane is a layout surface only when it holds this share of the cloud;
// smaller ones are furniture.
constexpr double kMinPlaneShare = 0.08;
constexpr int kMaxPlanes = 4;
constexpr int kRansacIterations = 300;
// Two normals are near-orthogonal (the second plane gives the box's second
// axis) below this |cos|, and a plane is a face of the box when its normal
// is within acos(kFaceCos) of the face's axis.
constexpr float kOrthogonalCos = 0.5f;
constexpr float kFaceCos = 0.94f;  // 20 degrees
// The box spans the 1st to 99th percentile of the points along each axis:
// a few stray points (a floater, a wrong depth) do not push a wall out.
constexpr double kExtentPercentile = 0.01;
// A plane within this share of the box's extent of a bound is that face
// (widening the box to it); further in, it is furniture (a table top).
constexpr float kFaceSlack = 0.1f;

float Percentile(std::vector<float> values, double p) {
  const auto k = static_cast<std::ptrdiff_t>(
      std::lround(p * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[static_cast<std::size_t>(k)];
}

// The cloud's size for the RANSAC band: the median distance of its points
// to its per-coordinate median point.
double RobustScale(const PointCloud& cloud) {
  Eigen::Vector3f centre;
  for (int j = 0; j < 3; ++j) {
    std::vector<float> c(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) c[i] = cloud.points[i][j];
    centre[j] = Percentile(std::move(c), 0.5);
  }
  std::vector<float> d(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    d[i] = (cloud.points[i] - centre).norm();
  return Percentile(std::move(d), 0.5);
}

// Up to kMaxPlanes planes, largest first, each fitted to what the earlier
// ones left; inliers index `cloud`.
std::vector<Plane> DominantPlanes(const PointCloud& cloud, double threshold) {
  std::vector<Plane> planes;
  std::vector<std::size_t> left(cloud.size());
  for (std::size_t i = 0; i < left.size(); ++i) left[i] = i;
  const auto min_inliers = static_cast<std::size_t>(
      std::ceil(kMinPlaneShare * static_cast<double>(cloud.size())));
  while (static_cast<int>(planes.size()) < kMaxPlanes &&
         left.size() >= min_inliers) {
    PointCloud rest;
    rest.points.reserve(left.size());
    for (const std::size_t i : left) rest.points.push_back(cloud.points[i]);
    std::optional<Plane> plane =
        FitDominantPlane(rest, threshold, kRansacIterations);
    if (!plane || plane->inliers.size() < min_inliers) break;
    std::vector<std::uint8_t> taken(left.size(), 0);
    for (std::size_t& i : plane->inliers) {
      taken[i] = 1;
      i = left[i];
    }
    std::vector<std::size_t> still;
    for (std::size_t k = 0; k < left.size(); ++k)
      if (!taken[k]) still.push_back(left[k]);
    left = std::move(still);
    planes.push_back(std::move(*plane));
  }
  return planes;
}

// The direction in which the points, projected on the plane normal to
// `axis`, spread the most.
Eigen::Vector3f PrincipalDirectionAcross(const PointCloud& cloud,
                                         const Eigen::Vector3f& axis) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : cloud.points) mean += p.cast<double>();
  mean /= static_cast<double>(cloud.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  const Eigen::Vector3d a = axis.cast<double>();
  for (const auto& p : cloud.points) {
    Eigen::Vector3d q = p.cast<double>() - mean;
    q -= q.dot(a) * a;
    cov += q * q.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3f d = eig.eigenvectors().col(2).cast<float>();
  d -= d.dot(axis) * axis;  // exact orthogonality against rounding
  if (d.norm() < 1e-6f) d = axis.unitOrthogonal();
  return d.normalized();
}

Eigen::Vector3f MeanColour(const PointCloud& cloud,
                           const std::vector<std::size_t>* subset) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  const auto add = [&](std::size_t i) {
    sum += cloud.colors[i].cast<double>();
    ++n;
  };
  if (subset) {
    for (const std::size_t i : *subset) add(i);
  } else {
    for (std::size_t i = 0; i < cloud.size(); ++i) add(i);
  }
  return n ? Eigen::Vector3f((sum / static_cast<double>(n)).cast<float>())
           : Eigen::Vector3f::Constant(0.5f);
}

}  // namespace

std::optional<Layout::Hit> Layout::Exit(
    const Eigen::Vector3f& origin, const Eigen::Vector3f& direction) const {
  if (!valid) return std::nullopt;
  const Eigen::Vector3f o = axes.transpose() * origin;
  const Eigen::Vector3f d = axes.transpose() * direction;
  float t_near = -std::numeric_limits<float>::infinity();
  float t_far = std::numeric_limits<float>::infinity();
  int face = -1;
  for (int j = 0; j < 3; ++j) {
    if (std::abs(d[j]) < 1e-12f) {
      if (o[j] < lo[j] || o[j] > hi[j]) return std::nullopt;
      continue;
    }
    const float t_lo = (lo[j] - o[j]) / d[j], t_hi = (hi[j] - o[j]) / d[j];
    t_near = std::max(t_near, std::min(t_lo, t_hi));
    const float out = std::max(t_lo, t_hi);
    if (out < t_far) {
      t_far = out;
      face = 2 * j + (d[j] > 0 ? 1 : 0);
    }
  }
  if (face < 0 || !(t_far > std::max(t_near, 0.0f)) || !std::isfinite(t_far))
    return std::nullopt;
  return Hit{t_far, face};
}

std::optional<int> Layout::PlaneFaceAt(const Eigen::Vector3f& point,
                                       float tolerance) const {
  if (!valid) return std::nullopt;
  const Eigen::Vector3f q = axes.transpose() * point;
  const auto inside = [&](int j) {
    return q[j] >= lo[j] - tolerance && q[j] <= hi[j] + tolerance;
  };
  for (int face = 0; face < 6; ++face) {
    const int j = face / 2;
    if (!on_plane[face]) continue;
    const float at = face % 2 ? hi[j] : lo[j];
    if (std::abs(q[j] - at) <= tolerance && inside((j + 1) % 3) &&
        inside((j + 2) % 3))
      return face;
  }
  return std::nullopt;
}

bool Layout::Beyond(const Eigen::Vector3f& point) const {
  if (!valid) return false;
  const Eigen::Vector3f q = axes.transpose() * point;
  bool past = false;
  for (int face = 0; face < 6; ++face) {
    const int j = face / 2;
    const float at = face % 2 ? hi[j] : lo[j];
    if (on_plane[face]) {
      if (std::abs(q[j] - at) <= band) return false;
    } else {
      past = past || (face % 2 ? q[j] > at + band : q[j] < at - band);
    }
  }
  return past;
}

Layout FitLayout(const PointCloud& cloud,
                 const std::vector<Eigen::Vector3f>& viewpoints) {
  Layout layout;
  if (cloud.size() < kLayoutMinPoints) return layout;
  const bool coloured = cloud.colors.size() == cloud.size();
  const double scale = RobustScale(cloud);
  if (!(scale > 0)) return layout;
  const double band = kPlaneTolerance * scale;
  layout.band = static_cast<float>(band);
  const std::vector<Plane> planes = DominantPlanes(cloud, band);
  if (planes.empty()) return layout;

  const Eigen::Vector3f a0 = planes.front().normal;
  Eigen::Vector3f a1 = Eigen::Vector3f::Zero();
  for (std::size_t k = 1; k < planes.size() && a1.isZero(); ++k) {
    const Eigen::Vector3f& n = planes[k].normal;
    if (std::abs(n.dot(a0)) < kOrthogonalCos)
      a1 = (n - n.dot(a0) * a0).normalized();
  }
  if (a1.isZero()) a1 = PrincipalDirectionAcross(cloud, a0);
  layout.axes.col(0) = a0;
  layout.axes.col(1) = a1;
  layout.axes.col(2) = a0.cross(a1).normalized();

  std::vector<float> along(cloud.size());
  for (int j = 0; j < 3; ++j) {
    for (std::size_t i = 0; i < cloud.size(); ++i)
      along[i] = layout.axes.col(j).dot(cloud.points[i]);
    layout.lo[j] = Percentile(along, kExtentPercentile);
    layout.hi[j] = Percentile(along, 1.0 - kExtentPercentile);
  }
  if (!((layout.hi - layout.lo).minCoeff() > 0)) return layout;

  // The cameras' mean position along each axis, which tells the side of a
  // thin cloud its plane bounds (without cameras: below it).
  Eigen::Vector3f viewer =
      Eigen::Vector3f::Constant(-std::numeric_limits<float>::infinity());
  if (!viewpoints.empty()) {
    viewer.setZero();
    for (const Eigen::Vector3f& v : viewpoints) viewer += v;
    viewer = layout.axes.transpose() * viewer /
             static_cast<float>(viewpoints.size());
  }
  layout.mean_colour =
      coloured ? MeanColour(cloud, nullptr) : Eigen::Vector3f::Constant(0.5f);
  layout.colours.fill(layout.mean_colour);
  for (const Plane& plane : planes) {  // largest first: it keeps its face
    for (int j = 0; j < 3; ++j) {
      if (std::abs(plane.normal.dot(layout.axes.col(j))) < kFaceCos) continue;
      std::vector<float> at;
      at.reserve(plane.inliers.size());
      for (const std::size_t i : plane.inliers)
        at.push_back(layout.axes.col(j).dot(cloud.points[i]));
      const float c = Percentile(std::move(at), 0.5);
      // Within its inlier band of a bound, a plane is that face however
      // thin the cloud is along its normal.
      const float slack = std::max(kFaceSlack * (layout.hi[j] - layout.lo[j]),
                                   static_cast<float>(band));
      const bool at_lo = c <= layout.lo[j] + slack;
      const bool at_hi = c >= layout.hi[j] - slack;
      int face = -1;
      if (at_lo && at_hi) {  // a thin cloud (one wall): the side past it
        face = 2 * j + (viewer[j] < c ? 1 : 0);
      } else if (at_lo || at_hi) {
        face = 2 * j + (at_hi ? 1 : 0);
      }
      if (face < 0 || layout.on_plane[face]) continue;
      layout.on_plane[face] = true;
      if (face % 2 == 0) {
        layout.lo[j] = std::min(layout.lo[j], c);
      } else {
        layout.hi[j] = std::max(layout.hi[j], c);
      }
      if (coloured) layout.colours[face] = MeanColour(cloud, &plane.inliers);
    }
  }
  layout.valid = true;
  return layout;
}

void FitSliverWalls(const PointCloud& beyond, Layout* layout) {
  if (!layout->valid) return;
  const bool coloured = beyond.colors.size() == beyond.size();
  const float band = layout->band;
  struct Wall {
    int face;
    float at;
    Eigen::Vector3f colour;
  };
  std::vector<std::uint8_t> past_box(beyond.size());  // Layout::Beyond, once
  for (std::size_t i = 0; i < beyond.size(); ++i)
    past_box[i] = layout->Beyond(beyond.points[i]);
  std::vector<Wall> walls;  // applied after every face is looked at
  for (int face = 0; face < 6; ++face) {
    if (layout->on_plane[face]) continue;
    const int j = face / 2;
    const bool high = face % 2 == 1;
    const float bound = high ? layout->hi[j] : layout->lo[j];
    std::vector<std::pair<float, std::size_t>> past;  // (along axis j, index)
    for (std::size_t i = 0; i < beyond.size(); ++i) {
      const Eigen::Vector3f& p = beyond.points[i];
      const float q = layout->axes.col(j).dot(p);
      if (past_box[i] && (high ? q > bound + band : q < bound - band))
        past.emplace_back(q, i);
    }
    if (past.size() < kSliverWallMinPoints) continue;
    std::sort(past.begin(), past.end());
    // The most points within one plane's band (a window two bands wide).
    std::size_t first = 0, count = 0;
    for (std::size_t a = 0, b = 0; b < past.size(); ++b) {
      while (past[b].first - past[a].first > 2 * band) ++a;
      if (b - a + 1 > count) {
        count = b - a + 1;
        first = a;
      }
    }
    if (count < kSliverWallMinPoints ||
        static_cast<double>(count) <
            kSliverWallShare * static_cast<double>(past.size()))
      continue;
    Wall wall{face, past[first + count / 2].first, layout->mean_colour};
    if (std::abs(wall.at - bound) < kSliverWallGapBands * band) continue;
    if (coloured) {
      std::vector<std::size_t> on_wall;
      for (std::size_t k = first; k < first + count; ++k)
        on_wall.push_back(past[k].second);
      wall.colour = MeanColour(beyond, &on_wall);
    }
    walls.push_back(wall);
  }
  for (const Wall& wall : walls) {
    const int j = wall.face / 2;
    (wall.face % 2 ? layout->hi : layout->lo)[j] = wall.at;
    layout->on_plane[wall.face] = true;
    layout->colours[wall.face] = wall.colour;
  }
}

void HoldViewpoints(const std::vector<Eigen::Vector3f>& viewpoints,
                    float margin, Layout* layout) {
  if (!layout->valid) return;
  for (const Eigen::Vector3f& v : viewpoints) {
    const Eigen::Vector3f q = layout->axes.transpose() * v;
    for (int j = 0; j < 3; ++j) {
      if (!layout->on_plane[2 * j])
        layout->lo[j] = std::min(layout->lo[j], q[j] - margin);
      if (!layout->on_plane[2 * j + 1])
        layout->hi[j] = std::max(layout->hi[j], q[j] + margin);
    }
  }
}

void RenderLayout(const Layout& layout, const RasterCamera& camera,
                  cv::Mat* depth, cv::Mat* rgb) {
  *depth = cv::Mat(camera.height, camera.width, CV_32FC1, cv::Scalar(0));
  const Eigen::Vector3f& m = layout.mean_colour;
  *rgb = cv::Mat(camera.height, camera.width, CV_32FC3,
                 cv::Scalar(m[0], m[1], m[2]));
  if (!layout.valid) return;
  const Eigen::Vector3f origin = camera.Center();
  const Eigen::Matrix3f world_from_cam = camera.rotation.transpose();
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      // A camera ray with z = 1: t along it is the z-depth.
      const Eigen::Vector3f ray =
          world_from_cam * Eigen::Vector3f((x + 0.5f - camera.cx) / camera.fx,
                                           (y + 0.5f - camera.cy) / camera.fy,
                                           1.0f);
      const std::optional<Layout::Hit> hit = layout.Exit(origin, ray);
      if (!hit) continue;
      depth->at<float>(y, x) = hit->t;
      const Eigen::Vector3f& c = layout.colours[hit->face];
      rgb->at<cv::Vec3f>(y, x) = cv::Vec3f(c[0], c[1], c[2]);
    }
  }
}

PointCloud SampleLayoutFaces(const Layout& layout, float spacing) {
  PointCloud cloud;
  if (!layout.valid || !(spacing > 0)) return cloud;
  for (int face = 0; face < 6; ++face) {
    const int j = face / 2, a = (j + 1) % 3, b = (j + 2) % 3;
    const float at = face % 2 ? layout.hi[j] : layout.lo[j];
    const int na = std::max(
        1,
        static_cast<int>(std::ceil((layout.hi[a] - layout.lo[a]) / spacing)));
    const int nb = std::max(
        1,
        static_cast<int>(std::ceil((layout.hi[b] - layout.lo[b]) / spacing)));
    for (int ia = 0; ia < na; ++ia) {
      for (int ib = 0; ib < nb; ++ib) {
        Eigen::Vector3f q;
        q[j] = at;
        q[a] = layout.lo[a] + (ia + 0.5f) * (layout.hi[a] - layout.lo[a]) / na;
        q[b] = layout.lo[b] + (ib + 0.5f) * (layout.hi[b] - layout.lo[b]) / nb;
        cloud.points.push_back(layout.axes * q);
        cloud.colors.push_back(layout.colours[face]);
      }
    }
  }
  return cloud;
}

}  // namespace pano4d
