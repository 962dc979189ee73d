#include "src/gs/surface_loss.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "src/core/error.h"
#include "src/core/image.h"

namespace pano4d {
namespace {

constexpr int kWidth = 40, kHeight = 30;

RasterCameraT<double> Camera() {
  RasterCameraT<double> c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = c.fy = 36;
  c.cx = kWidth / 2.0;
  c.cy = kHeight / 2.0;
  return c;  // at the origin, looking down +z
}

// The plane n . X = d seen by Camera(): z-depth per pixel (ray through the
// pixel centre), with the plane's unit normal.
const Eigen::Vector3d kPlaneNormal =
    Eigen::Vector3d(0.3, -0.4, -1).normalized();
constexpr double kPlaneOffset = -3.0;

std::vector<float> PlaneDepth(const RasterCameraT<double>& c) {
  std::vector<float> depth(static_cast<std::size_t>(c.width) * c.height);
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const Eigen::Vector3d ray((x + 0.5 - c.cx) / c.fx,
                                (y + 0.5 - c.cy) / c.fy, 1.0);
      depth[static_cast<std::size_t>(y) * c.width + x] =
          static_cast<float>(kPlaneOffset / kPlaneNormal.dot(ray));
    }
  return depth;
}

// The point of the plane seen at pixel (x, y).
Eigen::Vector3d PlanePoint(const RasterCameraT<double>& c, double x, double y) {
  const Eigen::Vector3d ray((x - c.cx) / c.fx, (y - c.cy) / c.fy, 1.0);
  return ray * (kPlaneOffset / kPlaneNormal.dot(ray));
}

// Appends a Gaussian at `mean` whose local axes are `rot`'s columns with
// standard deviations `scales`.
void Add(GaussianModelT<double>* m, const Eigen::Vector3d& mean,
         const Eigen::Matrix3d& rot, const Eigen::Vector3d& scales) {
  const Eigen::Quaterniond q(rot);
  for (int k = 0; k < 3; ++k) m->means.push_back(mean(k));
  for (int k = 0; k < 3; ++k) m->log_scales.push_back(std::log(scales(k)));
  for (double v : {q.w(), q.x(), q.y(), q.z()}) m->quats.push_back(v);
  m->opacities.push_back(0.0);
  for (int k = 0; k < 3; ++k) m->sh.push_back(0.0);
}

// A rotation whose third column is `axis`.
Eigen::Matrix3d FrameWithThirdAxis(const Eigen::Vector3d& axis) {
  const Eigen::Vector3d a = axis.normalized();
  const Eigen::Vector3d u = a.unitOrthogonal();
  Eigen::Matrix3d r;
  r << u, a.cross(u), a;
  return r;
}

NormalFlatness Evaluate(const GaussianModelT<double>& m, double weight = 1.0,
                        std::vector<double>* d_ls = nullptr,
                        std::vector<double>* d_q = nullptr) {
  std::vector<double> ls(m.size() * 3, 0.0), q(m.size() * 4, 0.0);
  return NormalFlatnessLoss(m, Camera(), PlaneDepth(Camera()), weight, 0.03,
                            d_ls ? d_ls : &ls, d_q ? d_q : &q);
}

TEST(DepthNormalTest, PlaneNormalIsRecoveredAndEdgesAreRefused) {
  const RasterCameraT<double> c = Camera();
  std::vector<float> depth = PlaneDepth(c);
  Eigen::Vector3d n;
  ASSERT_TRUE(DepthNormalAt(depth, c, 20, 15, &n));
  EXPECT_NEAR(std::abs(n.dot(kPlaneNormal)), 1.0, 1e-4) << n.transpose();
  EXPECT_FALSE(DepthNormalAt(depth, c, 0, 15, &n)) << "the border";
  // A step of 10% between columns 9 and 10: a depth edge.
  for (int y = 0; y < kHeight; ++y)
    for (int x = 10; x < kWidth; ++x) depth[y * kWidth + x] *= 1.1f;
  EXPECT_FALSE(DepthNormalAt(depth, c, 10, 15, &n));
  EXPECT_FALSE(DepthNormalAt(depth, c, 9, 15, &n));
  EXPECT_TRUE(DepthNormalAt(depth, c, 12, 15, &n));
  depth[15 * kWidth + 21] = 0;  // a neighbour without depth
  EXPECT_FALSE(DepthNormalAt(depth, c, 20, 15, &n));
}

TEST(NormalFlatnessTest, DiscInTheSurfaceScoresZeroFinAndNeedleDoNot) {
  const Eigen::Vector3d at = PlanePoint(Camera(), 20, 15);
  const Eigen::Matrix3d in_plane = FrameWithThirdAxis(kPlaneNormal);
  GaussianModelT<double> disc, fin, needle;
  Add(&disc, at, in_plane, {0.05, 0.05, 1e-4});
  // A fin: a disc standing out of the surface, containing its normal.
  Add(&fin, at, FrameWithThirdAxis(in_plane.col(0)), {0.05, 0.05, 1e-4});
  Add(&needle, at, in_plane, {1e-4, 1e-4, 0.05});
  EXPECT_NEAR(Evaluate(disc).loss, 0.0, 1e-5);
  EXPECT_NEAR(Evaluate(fin).loss, 0.5, 1e-3);
  EXPECT_NEAR(Evaluate(needle).loss, 1.0, 1e-3);
  EXPECT_EQ(Evaluate(fin).gaussians, 1);
  EXPECT_NEAR(Evaluate(needle, 0.1).loss, 0.1, 1e-4) << "scaled by the weight";
}

TEST(NormalFlatnessTest, ExtremeScalesStayFinite) {
  // exp(2 x 400) overflows a double, exp(-2 x 400) underflows to 0.
  const Eigen::Vector3d at = PlanePoint(Camera(), 20, 15);
  const Eigen::Matrix3d in_plane = FrameWithThirdAxis(kPlaneNormal);
  GaussianModelT<double> m;
  Add(&m, at, in_plane, {1, 1, 1});
  m.log_scales = {400, 400, -400};
  std::vector<double> d_ls(3, 0.0), d_q(4, 0.0);
  const NormalFlatness f = Evaluate(m, 1.0, &d_ls, &d_q);
  EXPECT_EQ(f.gaussians, 1);
  EXPECT_NEAR(f.loss, 0.0, 1e-9) << "a disc in the surface";
  m.log_scales = {-400, -400, 400};  // a needle along the normal
  EXPECT_NEAR(Evaluate(m).loss, 1.0, 1e-9);
  for (double g : d_ls) EXPECT_TRUE(std::isfinite(g));
  for (double g : d_q) EXPECT_TRUE(std::isfinite(g));
}

TEST(NormalFlatnessTest, GaussiansOffTheSurfaceOrOutsideAreLeftOut) {
  const Eigen::Matrix3d fin =
      FrameWithThirdAxis(FrameWithThirdAxis(kPlaneNormal).col(0));
  GaussianModelT<double> m;
  Add(&m, PlanePoint(Camera(), 20, 15) * 1.2, fin, {0.05, 0.05, 1e-3});
  Add(&m, PlanePoint(Camera(), 20, 15) * 0.8, fin, {0.05, 0.05, 1e-3});
  Add(&m, PlanePoint(Camera(), -5, 15), fin, {0.05, 0.05, 1e-3});
  Add(&m, -PlanePoint(Camera(), 20, 15), fin, {0.05, 0.05, 1e-3});  // behind
  std::vector<double> d_ls(m.size() * 3, 0.0), d_q(m.size() * 4, 0.0);
  const NormalFlatness f = Evaluate(m, 1.0, &d_ls, &d_q);
  EXPECT_EQ(f.gaussians, 0);
  EXPECT_EQ(f.loss, 0.0);
  for (double g : d_ls) EXPECT_EQ(g, 0.0);
  for (double g : d_q) EXPECT_EQ(g, 0.0);
}

TEST(NormalFlatnessTest, GradientMatchesCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  GaussianModelT<double> m;
  for (int i = 0; i < 12; ++i) {
    const Eigen::Vector3d at = PlanePoint(Camera(), 5 + 30 * (u(rng) + 1) / 2,
                                          5 + 20 * (u(rng) + 1) / 2);
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    const Eigen::Vector3d scales(std::exp(u(rng) - 3), std::exp(u(rng) - 3),
                                 std::exp(u(rng) - 3));
    Add(&m, at, q.normalized().toRotationMatrix(), scales);
    // Raw quaternions need not be unit: scale this one.
    for (int k = 0; k < 4; ++k) m.quats[4 * i + k] *= 1.7;
  }
  std::vector<double> d_ls(m.size() * 3, 0.0), d_q(m.size() * 4, 0.0);
  ASSERT_EQ(Evaluate(m, 0.7, &d_ls, &d_q).gaussians, 12);
  const double step = 1e-6;
  const auto check = [&](std::vector<double>* params,
                         const std::vector<double>& analytic,
                         const char* name) {
    for (std::size_t j = 0; j < params->size(); ++j) {
      const double saved = (*params)[j];
      (*params)[j] = saved + step;
      const double plus = Evaluate(m, 0.7).loss;
      (*params)[j] = saved - step;
      const double minus = Evaluate(m, 0.7).loss;
      (*params)[j] = saved;
      const double numeric = (plus - minus) / (2 * step);
      EXPECT_NEAR(analytic[j], numeric, 1e-6 + 1e-5 * std::abs(numeric))
          << name << " " << j;
    }
  };
  check(&m.log_scales, d_ls, "log_scale");
  check(&m.quats, d_q, "quat");
}

TEST(NormalFlatnessTest, DescentTurnsAFinIntoADiscInTheSurface) {
  GaussianModelT<double> m;
  // 60 degrees out of the surface: the third axis (the thin one) tilted.
  const Eigen::Matrix3d base = FrameWithThirdAxis(kPlaneNormal);
  const Eigen::Matrix3d tilted =
      Eigen::AngleAxisd(M_PI / 3, base.col(0)).toRotationMatrix() * base;
  Add(&m, PlanePoint(Camera(), 20, 15), tilted, {0.05, 0.03, 0.01});
  const double start = Evaluate(m).loss;
  for (int it = 0; it < 2000; ++it) {
    std::vector<double> d_ls(3, 0.0), d_q(4, 0.0);
    Evaluate(m, 1.0, &d_ls, &d_q);
    for (int k = 0; k < 3; ++k) m.log_scales[k] -= 0.05 * d_ls[k];
    for (int k = 0; k < 4; ++k) m.quats[k] -= 0.05 * d_q[k];
  }
  const double end = Evaluate(m).loss;
  EXPECT_GT(start, 0.2);
  EXPECT_LT(end, 0.01) << "from " << start;
  // The thin axis now lies along the surface normal.
  const Eigen::Quaterniond q(m.quats[0], m.quats[1], m.quats[2], m.quats[3]);
  const Eigen::Vector3d thin = q.normalized().toRotationMatrix().col(2);
  EXPECT_GT(std::abs(thin.dot(kPlaneNormal)), 0.95);
}

TEST(NormalFlatnessTest, MismatchedSizesAreRefused) {
  GaussianModelT<double> m;
  Add(&m, PlanePoint(Camera(), 20, 15), Eigen::Matrix3d::Identity(),
      {0.05, 0.05, 0.05});
  std::vector<double> d_ls(3, 0.0), d_q(4, 0.0), short_q(3, 0.0);
  EXPECT_THROW(NormalFlatnessLoss(m, Camera(), std::vector<float>(10, 1.0f),
                                  1.0, 0.03, &d_ls, &d_q),
               Error);
  EXPECT_THROW(NormalFlatnessLoss(m, Camera(), PlaneDepth(Camera()), 1.0, 0.03,
                                  &d_ls, &short_q),
               Error);
}

// Hidden depth: the plane is the moving object's visible surface; the mask
// covers the image's left half (x < 20).
std::vector<std::uint8_t> LeftHalfMask() {
  std::vector<std::uint8_t> mask(kWidth * kHeight, 0);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth / 2; ++x) mask[y * kWidth + x] = kMaskOn;
  return mask;
}

// A Gaussian on the ray through pixel (x, y)'s centre at `factor` times the
// plane's depth there.
Eigen::Vector3d OnRay(double x, double y, double factor) {
  return PlanePoint(Camera(), x, y) * factor;
}

constexpr double kThickness = 0.05;

HiddenDepth EvaluateHidden(const GaussianModelT<double>& m, std::size_t first,
                           std::vector<double>* d_means) {
  return HiddenDepthLoss(m, first, Camera(), PlaneDepth(Camera()),
                         LeftHalfMask(), 1.0, kThickness, d_means);
}

TEST(HiddenDepthTest, OnlyMovingGaussiansHiddenTooDeepInTheMaskCount) {
  GaussianModelT<double> m;
  const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d s(0.02, 0.02, 0.02);
  Add(&m, OnRay(8.5, 10.5, 1.3), id, s);      // 0: static row, left out
  Add(&m, OnRay(8.5, 10.5, 1.3), id, s);      // 1: 30% behind: hinge 0.25
  Add(&m, OnRay(10.5, 12.5, 1.03), id, s);    // 2: within the thickness: 0
  Add(&m, OnRay(12.5, 5.5, 0.8), id, s);      // 3: in front: 0
  Add(&m, OnRay(30.5, 10.5, 1.5), id, s);     // 4: outside the mask, left out
  Add(&m, Eigen::Vector3d(0, 0, -1), id, s);  // 5: behind the camera
  std::vector<double> d_means(m.size() * 3, 0.0);
  const HiddenDepth r = EvaluateHidden(m, 1, &d_means);
  EXPECT_EQ(r.gaussians, 3);
  EXPECT_EQ(r.hidden, 1);
  EXPECT_NEAR(r.loss, (0.3 - kThickness) / 3, 1e-5);
  // Only the hidden one is pushed, along the camera's +z (towards the
  // camera under descent).
  for (int i : {0, 2, 3, 4, 5})
    for (int k = 0; k < 3; ++k) EXPECT_EQ(d_means[3 * i + k], 0.0) << i;
  EXPECT_GT(d_means[3 * 1 + 2], 0.0);
  EXPECT_NEAR(d_means[3 * 1], 0.0, 1e-12);
  EXPECT_NEAR(d_means[3 * 1 + 1], 0.0, 1e-12);
}

TEST(HiddenDepthTest, GradientMatchesCentralDifferences) {
  // A rotated camera, so that the depth axis is not a world axis; Gaussians
  // hidden at several depths and one within the thickness.
  RasterCameraT<double> camera = Camera();
  camera.rotation =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, -2, 0.5).normalized())
          .toRotationMatrix();
  camera.translation = Eigen::Vector3d(0.1, -0.2, 0.3);
  const std::vector<float> depth = PlaneDepth(Camera());
  GaussianModelT<double> m;
  const Eigen::Matrix3d id = Eigen::Matrix3d::Identity();
  for (auto [x, y, f] : {std::tuple{5.5, 6.5, 1.2},
                         {9.5, 20.5, 1.4},
                         {14.5, 14.5, 1.01},
                         {3.5, 25.5, 1.1}}) {
    // In camera coordinates on the ray, then to the world.
    const Eigen::Vector3d c = OnRay(x, y, f);
    Add(&m, camera.rotation.transpose() * (c - camera.translation), id,
        {0.02, 0.02, 0.02});
  }
  const auto loss = [&](const GaussianModelT<double>& model,
                        std::vector<double>* g) {
    std::vector<double> scratch(model.size() * 3, 0.0);
    return HiddenDepthLoss(model, 0, camera, depth, LeftHalfMask(), 0.7,
                           kThickness, g ? g : &scratch)
        .loss;
  };
  std::vector<double> d_means(m.size() * 3, 0.0);
  EXPECT_GT(loss(m, &d_means), 0.0);
  constexpr double kStep = 1e-6;
  for (std::size_t k = 0; k < m.means.size(); ++k) {
    GaussianModelT<double> plus = m, minus = m;
    plus.means[k] += kStep;
    minus.means[k] -= kStep;
    const double numeric =
        (loss(plus, nullptr) - loss(minus, nullptr)) / (2 * kStep);
    EXPECT_NEAR(d_means[k], numeric, 1e-6 + 1e-4 * std::abs(numeric)) << k;
  }
}

TEST(HiddenDepthTest, DescentBringsAHiddenGaussianToTheSurface) {
  GaussianModelT<double> m;
  Add(&m, OnRay(8.5, 10.5, 1.4), Eigen::Matrix3d::Identity(),
      {0.02, 0.02, 0.02});
  for (int step = 0; step < 2000; ++step) {
    std::vector<double> d_means(3, 0.0);
    if (EvaluateHidden(m, 0, &d_means).hidden == 0) break;
    for (int k = 0; k < 3; ++k) m.means[k] -= 0.5 * d_means[k];
  }
  std::vector<double> d_means(3, 0.0);
  const HiddenDepth r = EvaluateHidden(m, 0, &d_means);
  EXPECT_EQ(r.gaussians, 1);
  EXPECT_EQ(r.hidden, 0);
  const double surface = PlaneDepth(Camera())[10 * kWidth + 8];
  EXPECT_LE(m.means[2], surface * (1 + kThickness) + 1e-9);
  EXPECT_GT(m.means[2], surface);
}

TEST(HiddenDepthTest, MismatchedSizesAreRefused) {
  GaussianModelT<double> m;
  Add(&m, OnRay(8.5, 10.5, 1.3), Eigen::Matrix3d::Identity(),
      {0.02, 0.02, 0.02});
  std::vector<double> d_means(3, 0.0), short_means(2, 0.0);
  EXPECT_THROW(
      HiddenDepthLoss(m, 0, Camera(), PlaneDepth(Camera()),
                      std::vector<std::uint8_t>(10, 1), 1.0, 0.05, &d_means),
      Error);
  EXPECT_THROW(HiddenDepthLoss(m, 0, Camera(), PlaneDepth(Camera()),
                               LeftHalfMask(), 1.0, 0.05, &short_means),
               Error);
}

}  // namespace
}  // namespace pano4d
