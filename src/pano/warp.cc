#include "src/pano/warp.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

// A barycentric weight this far below zero still counts as inside: a pixel
// centre on a shared edge or on a vertex (a frame warped into its own
// camera) must not fall between two triangles by rounding.
constexpr double kInsideTolerance = 1e-6;
// Landings farther out than this (pixels) come from points just in front of
// the target camera; edge functions lose their precision there.
constexpr double kMaxCoordinate = 1e7;

void CheckInput(const cv::Mat& rgb, const cv::Mat& depth,
                const RasterCamera& source, const cv::Mat& valid) {
  const auto size = [](const cv::Mat& m) { return SizeText(m.cols, m.rows); };
  const std::string expected = SizeText(source.width, source.height);
  if (rgb.type() != CV_32FC3 || rgb.cols != source.width ||
      rgb.rows != source.height) {
    throw Error(
        "warp", "rgb", size(rgb),
        "expected a CV_32FC3 image of the source camera's size " + expected);
  }
  if (depth.type() != CV_32FC1 || depth.size() != rgb.size()) {
    throw Error(
        "warp", "depth", size(depth),
        "expected a CV_32FC1 map of the source camera's size " + expected);
  }
  if (!valid.empty() &&
      (valid.type() != CV_8UC1 || valid.size() != rgb.size())) {
    throw Error(
        "warp", "valid", size(valid),
        "expected a CV_8UC1 mask of the source camera's size " + expected);
  }
}

// A point's landing in the target: pixel position (centres at +0.5) and
// z-depth (<= 0: behind the target camera). Double: a vertex that lands on a
// pixel centre must give that pixel its own values, not a mix by 1e-5 of its
// neighbours'.
struct Landing {
  double u = 0, v = 0, z = 0;
  bool Lands() const {
    return z > 0 && std::abs(u) < kMaxCoordinate &&
           std::abs(v) < kMaxCoordinate;
  }
};

// Source pixel coordinates and z-depth to target landings.
class Projector {
 public:
  Projector(const RasterCamera& source, const RasterCamera& target)
      : source_(source), target_(target) {
    // target_from_source from the rotations made orthonormal in double (a
    // float rotation is one to 1e-7, which would move a frame warped into
    // its own camera by 1e-5 px): that frame lands on its pixel centres.
    const auto orthonormal = [](const Eigen::Matrix3f& r) {
      return Eigen::Quaterniond(r.cast<double>())
          .normalized()
          .toRotationMatrix();
    };
    rotation_ =
        orthonormal(target.rotation) * orthonormal(source.rotation).transpose();
    translation_ = target.translation.cast<double>() -
                   rotation_ * source.translation.cast<double>();
  }
  double FocalAreaRatio() const {
    return static_cast<double>(target_.fx) * target_.fy /
           (static_cast<double>(source_.fx) * source_.fy);
  }
  // The point at continuous source pixel position (x, y) and z-depth z.
  Landing Land(double x, double y, double z) const {
    const Eigen::Vector3d p_src = source_.CameraPoint(x, y, z);
    const Eigen::Vector3d p = rotation_ * p_src + translation_;
    Landing l;
    l.z = p.z();
    if (!(p.z() > 0)) return l;
    l.u = target_.fx * p.x() / p.z() + target_.cx;
    l.v = target_.fy * p.y() / p.z() + target_.cy;
    return l;
  }

 private:
  const RasterCamera& source_;
  const RasterCamera& target_;
  Eigen::Matrix3d rotation_;
  Eigen::Vector3d translation_;
};

// The source pixels as mesh vertices, one per pixel (row-major): the source
// log-depth (NaN without depth) and the landing of the pixel's centre.
struct Vertices {
  int width = 0, height = 0;
  std::vector<float> z, log_z;  // source z-depth; 0 and NaN without
  std::vector<Landing> landing;
  // Target pixels per source pixel, in area, of a patch facing both cameras
  // at the same distance from each: the focal lengths' ratio squared.
  double focal_area_ratio = 1;
  bool Has(int p) const { return !std::isnan(log_z[p]); }
};

// How much larger triangle (a, b, c) is in the target than a patch at the
// same distances that faces both cameras: 1 for a surface the target sees
// at the angle the source does (however much closer), about
// cos(target angle) / cos(source angle) for one it sees more frontally.
double Stretch(const Vertices& m, int a, int b, int c) {
  const Landing &la = m.landing[a], &lb = m.landing[b], &lc = m.landing[c];
  const double area = 0.5 * std::abs((lb.u - la.u) * (lc.v - la.v) -
                                     (lb.v - la.v) * (lc.u - la.u));
  const double closer = (m.z[a] / la.z + m.z[b] / lb.z + m.z[c] / lc.z) / 3;
  // A triangle covers half a source pixel.
  return area / (0.5 * m.focal_area_ratio * closer * closer);
}

void LiftVertices(const cv::Mat& depth, const cv::Mat& valid,
                  const Projector& projector, Vertices* out) {
  Vertices& m = *out;
  m.width = depth.cols;
  m.height = depth.rows;
  m.z.assign(depth.total(), 0.0f);
  m.log_z.assign(depth.total(), std::numeric_limits<float>::quiet_NaN());
  m.landing.assign(depth.total(), Landing());
  m.focal_area_ratio = projector.FocalAreaRatio();
  for (int y = 0; y < m.height; ++y) {
    const float* d = depth.ptr<float>(y);
    const std::uint8_t* ok = valid.empty() ? nullptr : valid.ptr<uint8_t>(y);
    for (int x = 0; x < m.width; ++x) {
      const float z = d[x];
      if (!(z > 0) || !std::isfinite(z) || (ok && !ok[x])) continue;
      const int i = y * m.width + x;
      m.z[i] = z;
      m.log_z[i] = std::log(z);
      m.landing[i] = projector.Land(x + 0.5, y + 0.5, z);
    }
  }
}

// The mesh's edges, indexed by the top-left pixel (x, y) of their 2x2 block:
// right (x, y)-(x+1, y), down (x, y)-(x, y+1), diagonal (x, y)-(x+1, y+1),
// anti-diagonal (x+1, y)-(x, y+1).
enum Direction { kRight = 0, kDown, kDiagonal, kAntiDiagonal };
constexpr int kDirections = 4;
constexpr int kEdgeFrom[kDirections][2] = {{0, 0}, {0, 0}, {0, 0}, {1, 0}};
constexpr int kEdgeTo[kDirections][2] = {{1, 0}, {0, 1}, {1, 1}, {0, 1}};

// Per direction and block: the edge's log-depth step (< 0 where a vertex
// has no depth or the edge leaves the image) and whether it crosses a depth
// discontinuity (ForwardWarp's criterion).
struct Breaks {
  std::array<std::vector<float>, kDirections> step;
  std::array<std::vector<std::uint8_t>, kDirections> broken;
};

void FindBreaks(const Vertices& m, Breaks* out) {
  const int w = m.width, h = m.height;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  Breaks& b = *out;
  for (int dir = 0; dir < kDirections; ++dir) {
    b.step[dir].assign(n, -1.0f);
    b.broken[dir].assign(n, 0);
    const int dx = std::max(kEdgeFrom[dir][0], kEdgeTo[dir][0]);
    const int dy = std::max(kEdgeFrom[dir][1], kEdgeTo[dir][1]);
    for (int y = 0; y + dy < h; ++y) {
      for (int x = 0; x + dx < w; ++x) {
        const int a = (y + kEdgeFrom[dir][1]) * w + x + kEdgeFrom[dir][0];
        const int c = (y + kEdgeTo[dir][1]) * w + x + kEdgeTo[dir][0];
        if (m.Has(a) && m.Has(c))
          b.step[dir][y * w + x] = std::abs(m.log_z[a] - m.log_z[c]);
      }
    }
  }
  constexpr int r = kWarpJumpWindow / 2;
  for (int dir = 0; dir < kDirections; ++dir) {
    const std::vector<float>& step = b.step[dir];
    for (int y = 0; y < h; ++y) {
      std::array<float, kWarpJumpWindow * kWarpJumpWindow> around;
      for (int x = 0; x < w; ++x) {
        const float s = step[y * w + x];
        if (!(s > kWarpMinJump)) continue;  // also skips edges that are none
        int count = 0;
        for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy)
          for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx)
            if (step[yy * w + xx] >= 0) around[count++] = step[yy * w + xx];
        // The upper median, over an edge and its neighbours of the same
        // direction.
        std::nth_element(around.begin(), around.begin() + count / 2,
                         around.begin() + count);
        if (s > kWarpJumpFactor * around[count / 2])
          b.broken[dir][y * w + x] = 1;
      }
    }
  }
}

// The z-buffered target: colour, z-depth (infinity where nothing landed),
// and whether a pixel holds a triangle of the mesh (rather than a rim).
struct Canvas {
  int width = 0, height = 0;
  std::vector<double> z;
  std::vector<cv::Vec3f> rgb;
  std::vector<std::uint8_t> mesh;
};

// What a triangle is: part of the mesh (plain z-test), or part of a rim
// footprint, which takes a mesh pixel only from a surface in front of it
// (by more than a step of kWarpMinJump: exp(-0.05)).
enum class Layer { kMesh, kRim };
const double kRimInFront = std::exp(-static_cast<double>(kWarpMinJump));

// Rasterises triangle (a, b, c) at the target's pixel centres,
// perspective-correct.
void RasteriseTriangle(const Landing& a, const Landing& b, const Landing& c,
                       const cv::Vec3f& ca, const cv::Vec3f& cb,
                       const cv::Vec3f& cc, Layer layer, Canvas* canvas) {
  if (!a.Lands() || !b.Lands() || !c.Lands()) return;
  const double e1x = b.u - a.u, e1y = b.v - a.v;
  const double e2x = c.u - a.u, e2y = c.v - a.v;
  const double area = e1x * e2y - e1y * e2x;  // twice the signed area
  if (!(std::abs(area) > 0)) return;          // seen edge-on by the target
  // Pixel centres x + 0.5 within the triangle's extent (a hair wider, for
  // centres on a vertex).
  constexpr double kSlack = 1e-6;
  const auto first = [](double lo) {
    return static_cast<int>(std::ceil(lo - 0.5 - kSlack));
  };
  const auto last = [](double hi) {
    return static_cast<int>(std::floor(hi - 0.5 + kSlack));
  };
  const int x0 = std::max(0, first(std::min({a.u, b.u, c.u})));
  const int x1 = std::min(canvas->width - 1, last(std::max({a.u, b.u, c.u})));
  const int y0 = std::max(0, first(std::min({a.v, b.v, c.v})));
  const int y1 = std::min(canvas->height - 1, last(std::max({a.v, b.v, c.v})));
  // 1 / z is affine in the target's pixels; attributes over z are too.
  const double ia = 1 / a.z, ib = 1 / b.z, ic = 1 / c.z;
  const double inv_area = 1 / area;
  for (int y = y0; y <= y1; ++y) {
    const double py = y + 0.5 - a.v;
    for (int x = x0; x <= x1; ++x) {
      const double px = x + 0.5 - a.u;
      double wb = (px * e2y - py * e2x) * inv_area;
      double wc = (e1x * py - e1y * px) * inv_area;
      double wa = 1 - wb - wc;
      if (wa < -kInsideTolerance || wb < -kInsideTolerance ||
          wc < -kInsideTolerance)
        continue;
      wa = std::max(wa, 0.0) * ia;
      wb = std::max(wb, 0.0) * ib;
      wc = std::max(wc, 0.0) * ic;
      const double z = 1 / (wa + wb + wc);
      const std::size_t p = static_cast<std::size_t>(y) * canvas->width + x;
      const bool rim_under_mesh = layer == Layer::kRim && canvas->mesh[p];
      if (!(z < (rim_under_mesh ? kRimInFront * canvas->z[p] : canvas->z[p])))
        continue;
      canvas->z[p] = z;
      canvas->rgb[p] = static_cast<float>(wa * z) * ca +
                       static_cast<float>(wb * z) * cb +
                       static_cast<float>(wc * z) * cc;
      canvas->mesh[p] = layer == Layer::kMesh;
    }
  }
}

// The mesh: per 2x2 block (indexed by its top-left pixel) the diagonal it
// is split along and its two triangles' stretch (Stretch(); NaN where the
// triangle was left out or a vertex does not land), and per vertex whether
// it lies on the mesh's rim.
struct Mesh {
  int width = 0;
  std::vector<std::uint8_t> anti_diagonal;
  std::vector<std::array<float, 2>> stretch;
  std::vector<std::uint8_t> rim;
  // The vertices of triangle k (0 or 1) of block p.
  std::array<int, 3> Corners(int p, int k) const {
    const int p10 = p + 1, p01 = p + width, p11 = p01 + 1;
    if (anti_diagonal[p])
      return k == 0 ? std::array<int, 3>{p, p10, p01}
                    : std::array<int, 3>{p10, p11, p01};
    return k == 0 ? std::array<int, 3>{p, p10, p11}
                  : std::array<int, 3>{p, p11, p01};
  }
};

// Two triangles per block, those with an edge across a break left out. A
// vertex is on the rim when a block around it lost a triangle (a break or a
// corner without depth), or on the image's border.
void BuildMesh(const Vertices& m, const Breaks& breaks, Mesh* out) {
  const int w = m.width, h = m.height;
  constexpr float kNone = std::numeric_limits<float>::quiet_NaN();
  Mesh& mesh = *out;
  mesh.width = w;
  mesh.anti_diagonal.assign(m.log_z.size(), 0);
  mesh.stretch.assign(m.log_z.size(), {kNone, kNone});
  mesh.rim.assign(m.log_z.size(), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (x == 0 || y == 0 || x == w - 1 || y == h - 1) mesh.rim[y * w + x] = 1;
  const auto broken = [&](int dir, int x, int y) {
    return breaks.broken[dir][y * w + x] != 0;
  };
  for (int y = 0; y + 1 < h; ++y) {
    for (int x = 0; x + 1 < w; ++x) {
      const int p00 = y * w + x, p10 = p00 + 1, p01 = p00 + w, p11 = p01 + 1;
      const bool h00 = m.Has(p00), h10 = m.Has(p10), h01 = m.Has(p01),
                 h11 = m.Has(p11);
      // Split along the diagonal whose ends agree better: at a corner of an
      // object, one triangle then lies wholly on the background.
      bool anti = !h00 || !h11;
      if (h00 && h10 && h01 && h11) {
        anti = breaks.step[kAntiDiagonal][p00] < breaks.step[kDiagonal][p00];
      }
      mesh.anti_diagonal[p00] = anti;
      const bool top = !broken(kRight, x, y),
                 bottom = !broken(kRight, x, y + 1);
      const bool left = !broken(kDown, x, y), right = !broken(kDown, x + 1, y);
      const bool d = !broken(anti ? kAntiDiagonal : kDiagonal, x, y);
      const bool keep[2] = {anti ? h00 && h10 && h01 && top && d && left
                                 : h00 && h10 && h11 && top && right && d,
                            anti ? h10 && h11 && h01 && right && bottom && d
                                 : h00 && h11 && h01 && d && bottom && left};
      for (int k = 0; k < 2; ++k) {
        if (!keep[k]) continue;
        const std::array<int, 3> t = mesh.Corners(p00, k);
        if (m.landing[t[0]].Lands() && m.landing[t[1]].Lands() &&
            m.landing[t[2]].Lands())
          mesh.stretch[p00][k] =
              static_cast<float>(Stretch(m, t[0], t[1], t[2]));
      }
      if (!keep[0] || !keep[1])
        mesh.rim[p00] = mesh.rim[p10] = mesh.rim[p01] = mesh.rim[p11] = 1;
    }
  }
}

// Whether the triangles of the 3 x 3 blocks around (x, y) are mostly
// stretched beyond kWarpMaxStretch: the surface there, not one triangle
// that depth noise drew long, was seen edge-on.
bool StretchedAround(const Mesh& mesh, int h, int x, int y) {
  const int w = mesh.width;
  std::array<float, 18> around;
  int count = 0;
  for (int yy = std::max(0, y - 1); yy <= std::min(h - 2, y + 1); ++yy)
    for (int xx = std::max(0, x - 1); xx <= std::min(w - 2, x + 1); ++xx)
      for (float s : mesh.stretch[yy * w + xx])
        if (!std::isnan(s)) around[count++] = s;
  std::nth_element(around.begin(), around.begin() + count / 2,
                   around.begin() + count);
  return around[count / 2] > kWarpMaxStretch;
}

// Rasterises the mesh's triangles, but those of a stretched surface.
void DrawMesh(const Vertices& m, const Mesh& mesh, const cv::Vec3f* colour,
              Canvas* canvas) {
  const int w = m.width, h = m.height;
  for (int y = 0; y + 1 < h; ++y) {
    for (int x = 0; x + 1 < w; ++x) {
      const int p = y * w + x;
      for (int k = 0; k < 2; ++k) {
        const float s = mesh.stretch[p][k];
        if (std::isnan(s)) continue;
        if (s > kWarpMaxStretch && StretchedAround(mesh, h, x, y)) continue;
        const auto [a, b, c] = mesh.Corners(p, k);
        RasteriseTriangle(m.landing[a], m.landing[b], m.landing[c], colour[a],
                          colour[b], colour[c], Layer::kMesh, canvas);
      }
    }
  }
}

// Each rim vertex also covers its pixel's footprint (the square the source
// pixel saw, at its depth): the mesh ends at pixel centres, so without it
// every break would widen by a pixel and a one-pixel structure would vanish.
void DrawRims(const Vertices& m, const std::vector<std::uint8_t>& rim,
              const Projector& projector, const cv::Vec3f* colour,
              Canvas* canvas) {
  for (int y = 0; y < m.height; ++y) {
    for (int x = 0; x < m.width; ++x) {
      const int i = y * m.width + x;
      if (!rim[i] || !m.Has(i)) continue;
      const double z = m.z[i];
      const Landing c00 = projector.Land(x, y, z);
      const Landing c10 = projector.Land(x + 1, y, z);
      const Landing c01 = projector.Land(x, y + 1, z);
      const Landing c11 = projector.Land(x + 1, y + 1, z);
      const cv::Vec3f& c = colour[i];
      RasteriseTriangle(c00, c10, c11, c, c, c, Layer::kRim, canvas);
      RasteriseTriangle(c00, c11, c01, c, c, c, Layer::kRim, canvas);
    }
  }
}

// One warp's buffers.
struct Scratch {
  Vertices vertices;
  Breaks breaks;
  Mesh mesh;
  Canvas canvas;
};

}  // namespace

WarpResult ForwardWarp(const cv::Mat& rgb, const cv::Mat& depth,
                       const RasterCamera& source, const RasterCamera& target,
                       const cv::Mat& valid) {
  CheckInput(rgb, depth, source, valid);
  const int tw = target.width, th = target.height;
  if (tw <= 0 || th <= 0) {
    throw Error("warp", "target", SizeText(tw, th),
                "the target camera has no pixels");
  }
  const cv::Mat colour_mat = rgb.isContinuous() ? rgb : rgb.clone();
  const cv::Vec3f* colour = colour_mat.ptr<cv::Vec3f>(0);
  const Projector projector(source, target);
  // Buffers kept per thread between calls (about 80 bytes a pixel, 11 MB
  // for 480 x 270): allocated afresh, their page faults took a third of a
  // warp's time.
  thread_local Scratch scratch;
  Vertices& m = scratch.vertices;
  LiftVertices(depth, valid, projector, &m);
  FindBreaks(m, &scratch.breaks);
  BuildMesh(m, scratch.breaks, &scratch.mesh);
  Canvas& canvas = scratch.canvas;
  canvas.width = tw;
  canvas.height = th;
  canvas.z.assign(static_cast<std::size_t>(tw) * th,
                  std::numeric_limits<double>::infinity());
  canvas.rgb.assign(canvas.z.size(), cv::Vec3f(0, 0, 0));
  canvas.mesh.assign(canvas.z.size(), 0);
  DrawMesh(m, scratch.mesh, colour, &canvas);
  DrawRims(m, scratch.mesh.rim, projector, colour, &canvas);

  WarpResult out;
  out.rgb = cv::Mat(th, tw, CV_32FC3, cv::Scalar::all(0));
  out.depth = cv::Mat(th, tw, CV_32FC1, cv::Scalar(0));
  out.mask = cv::Mat(th, tw, CV_8UC1, cv::Scalar(kMaskOn));
  for (int y = 0; y < th; ++y) {
    for (int x = 0; x < tw; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * tw + x;
      if (!std::isfinite(canvas.z[p])) continue;
      out.rgb.at<cv::Vec3f>(y, x) = canvas.rgb[p];
      out.depth.at<float>(y, x) = static_cast<float>(canvas.z[p]);
      out.mask.at<std::uint8_t>(y, x) = 0;
    }
  }
  return out;
}

int FillHoles(const WarpResult& from, WarpResult* into) {
  if (from.mask.size() != into->mask.size()) {
    throw Error("warp", "chained frame",
                SizeText(from.mask.cols, from.mask.rows),
                "expected the size of the frame it fills, " +
                    SizeText(into->mask.cols, into->mask.rows));
  }
  int filled = 0;
  for (int y = 0; y < into->mask.rows; ++y) {
    for (int x = 0; x < into->mask.cols; ++x) {
      if (!into->mask.at<std::uint8_t>(y, x) ||
          from.mask.at<std::uint8_t>(y, x))
        continue;
      into->rgb.at<cv::Vec3f>(y, x) = from.rgb.at<cv::Vec3f>(y, x);
      into->depth.at<float>(y, x) = from.depth.at<float>(y, x);
      into->mask.at<std::uint8_t>(y, x) = 0;
      ++filled;
    }
  }
  return filled;
}

std::int64_t CountCracks(const cv::Mat& mask, int kernel) {
  if (mask.type() != CV_8UC1) {
    throw Error("crack count", "mask", std::to_string(mask.type()),
                "expected a CV_8UC1 mask (OpenCV type " +
                    std::to_string(CV_8UC1) + ")");
  }
  if (kernel < 1) {
    throw Error("crack count", "kernel", std::to_string(kernel),
                "expected a positive size in pixels");
  }
  const cv::Mat covered = mask == 0;
  cv::Mat closed;
  // Outside the image is uncovered: a hole along the border is out of view.
  cv::morphologyEx(covered, closed, cv::MORPH_CLOSE,
                   cv::Mat::ones(kernel, kernel, CV_8U), cv::Point(-1, -1), 1,
                   cv::BORDER_CONSTANT, cv::Scalar(0));
  return cv::countNonZero(closed & (mask != 0));
}

double CrackFraction(const cv::Mat& mask, int kernel) {
  const std::int64_t cracks = CountCracks(mask, kernel);
  const int holes = cv::countNonZero(mask);
  return holes > 0 ? static_cast<double>(cracks) / holes : 0.0;
}

}  // namespace pano4d
