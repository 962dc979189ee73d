#include "src/core/camera.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "src/core/camera_check.h"
#include "src/core/error.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

constexpr int kW = 640;
constexpr int kH = 480;
constexpr double kRoundTripTolerancePx = 1e-9;

struct Case {
  std::string name;
  Camera camera;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

Camera Make(CameraModelId id, std::vector<double> params) {
  return Camera{id, kW, kH, std::move(params)};
}

// Every COLMAP model, with strong distortion (k1 = -0.4 and +0.4 for the
// polynomial models; fisheye lenses reaching past 80 degrees in the corners).
// Barrel cases use a focal length that keeps the corners on the one-to-one
// side of the distortion's fold.
std::vector<Case> StrongCases() {
  return {
      {"SIMPLE_PINHOLE", Make(CameraModelId::kSimplePinhole, {500, 320, 240})},
      {"PINHOLE", Make(CameraModelId::kPinhole, {500, 520, 310, 250})},
      {"SIMPLE_RADIAL_k-0.4",
       Make(CameraModelId::kSimpleRadial, {800, 320, 240, -0.4})},
      {"SIMPLE_RADIAL_k+0.4",
       Make(CameraModelId::kSimpleRadial, {500, 320, 240, 0.4})},
      {"RADIAL_k-0.4",
       Make(CameraModelId::kRadial, {800, 320, 240, -0.4, 0.05})},
      {"RADIAL_k+0.4", Make(CameraModelId::kRadial, {500, 320, 240, 0.4, 0.1})},
      {"OPENCV_k-0.4", Make(CameraModelId::kOpenCV,
                            {800, 810, 322, 238, -0.4, 0.05, 1e-3, -2e-3})},
      {"OPENCV_k+0.4", Make(CameraModelId::kOpenCV,
                            {500, 505, 320, 240, 0.4, 0.1, -1e-3, 1e-3})},
      {"FULL_OPENCV_k-0.4",
       Make(CameraModelId::kFullOpenCV, {800, 800, 320, 240, -0.4, 0.05, 1e-3,
                                         -1e-3, 0.01, 0.02, 0.01, 0.0})},
      {"FULL_OPENCV_k+0.4",
       Make(CameraModelId::kFullOpenCV, {500, 500, 320, 240, 0.4, 0.1, 1e-3,
                                         -1e-3, 0.01, 0.05, 0.01, 0.001})},
      {"OPENCV_FISHEYE",
       Make(CameraModelId::kOpenCVFisheye,
            {250, 252, 320, 240, 0.05, -0.01, 0.002, -0.0005})},
      {"FOV", Make(CameraModelId::kFOV, {400, 400, 320, 240, 0.9})},
      {"SIMPLE_RADIAL_FISHEYE",
       Make(CameraModelId::kSimpleRadialFisheye, {250, 320, 240, 0.05})},
      {"RADIAL_FISHEYE",
       Make(CameraModelId::kRadialFisheye, {250, 320, 240, 0.05, -0.01})},
      {"THIN_PRISM_FISHEYE", Make(CameraModelId::kThinPrismFisheye,
                                  {250, 250, 320, 240, 0.05, -0.01, 1e-3, -1e-3,
                                   0.002, -0.0005, 1e-3, -1e-3})},
  };
}

class CameraCaseTest : public ::testing::TestWithParam<Case> {};

TEST_P(CameraCaseTest, RoundTripOverWholeImageIncludingCorners) {
  const Camera& camera = GetParam().camera;
  ASSERT_NO_THROW(camera.Check());
  const RoundTripStats stats = MeasureRoundTrip(camera, 160, 120);
  EXPECT_EQ(stats.samples, 161 * 121);
  EXPECT_EQ(stats.failures, 0);
  EXPECT_LT(stats.max_error_px, kRoundTripTolerancePx);

  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(kW, 0), Eigen::Vector2d(0, kH),
        Eigen::Vector2d(kW, kH)}) {
    const UnprojectResult r = camera.Unproject(corner);
    ASSERT_TRUE(r.ok()) << GetParam().name << " corner " << corner.transpose()
                        << ": " << ToString(r.status);
    EXPECT_NEAR(r.ray.norm(), 1.0, 1e-15);
    EXPECT_GT(r.ray.z(), 0.0);
    const std::optional<Eigen::Vector2d> back = camera.Project(r.ray * 3.7);
    ASSERT_TRUE(back.has_value());
    EXPECT_LT((*back - corner).norm(), kRoundTripTolerancePx);
    EXPECT_LT(r.residual_px, kRoundTripTolerancePx);
  }
}

TEST_P(CameraCaseTest, PointsProjectAndUnprojectToTheSameRay) {
  const Camera& camera = GetParam().camera;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> px(0, kW), py(0, kH), depth(0.1, 50.0);
  for (int i = 0; i < 500; ++i) {
    const UnprojectResult r = camera.Unproject({px(rng), py(rng)});
    ASSERT_TRUE(r.ok());
    const Eigen::Vector3d point = r.ray * depth(rng);
    const std::optional<Eigen::Vector2d> pixel = camera.Project(point);
    ASSERT_TRUE(pixel.has_value());
    const UnprojectResult back = camera.Unproject(*pixel);
    ASSERT_TRUE(back.ok());
    EXPECT_LT(std::acos(std::min(1.0, back.ray.dot(point.normalized()))), 1e-7);
    EXPECT_LT((back.ray - point.normalized()).norm(), 1e-12);
  }
}

TEST_P(CameraCaseTest, JacobianMatchesCentralDifferences) {
  const Camera& camera = GetParam().camera;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> px(0, kW), py(0, kH), depth(0.5, 20.0);
  for (int i = 0; i < 200; ++i) {
    const UnprojectResult r = camera.Unproject({px(rng), py(rng)});
    ASSERT_TRUE(r.ok());
    const Eigen::Vector2d x = r.normalized;
    const Eigen::Matrix2d analytic = camera.JacobianNormalized(x);
    const double h = 1e-6 * std::max(1.0, x.norm());
    Eigen::Matrix2d numeric;
    for (int c = 0; c < 2; ++c) {
      Eigen::Vector2d e = Eigen::Vector2d::Zero();
      e(c) = h;
      numeric.col(c) = (camera.PixelFromNormalized(x + e) -
                        camera.PixelFromNormalized(x - e)) /
                       (2 * h);
    }
    EXPECT_LT((analytic - numeric).norm(), 1e-6 * std::max(1.0, numeric.norm()))
        << GetParam().name << " at " << x.transpose() << "\nanalytic\n"
        << analytic << "\nnumeric\n"
        << numeric;

    const Eigen::Vector3d point = r.ray * depth(rng);
    const Eigen::Matrix<double, 2, 3> analytic3 =
        camera.JacobianPointCam(point);
    Eigen::Matrix<double, 2, 3> numeric3;
    const double h3 = 1e-6 * point.norm();
    for (int c = 0; c < 3; ++c) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e(c) = h3;
      numeric3.col(c) =
          (camera.PixelFromNormalized((point + e).head<2>() / (point + e).z()) -
           camera.PixelFromNormalized((point - e).head<2>() /
                                      (point - e).z())) /
          (2 * h3);
    }
    EXPECT_LT((analytic3 - numeric3).norm(),
              1e-6 * std::max(1.0, numeric3.norm()));
  }
}

TEST_P(CameraCaseTest, RescaledCameraProjectsToScaledPixels) {
  const Camera& camera = GetParam().camera;
  const Camera half = camera.Rescaled(kW / 2, kH / 2);
  EXPECT_EQ(half.width, kW / 2);
  EXPECT_EQ(half.height, kH / 2);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> px(0, kW), py(0, kH);
  for (int i = 0; i < 100; ++i) {
    const UnprojectResult r = camera.Unproject({px(rng), py(rng)});
    ASSERT_TRUE(r.ok());
    const Eigen::Vector2d full = *camera.Project(r.ray);
    const Eigen::Vector2d small = *half.Project(r.ray);
    EXPECT_LT((small - 0.5 * full).norm(), 1e-9);
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, CameraCaseTest,
                         ::testing::ValuesIn(StrongCases()),
                         [](const auto& info) {
                           std::string name;
                           for (char c : info.param.name) {
                             name += c == '-'   ? std::string("minus")
                                     : c == '+' ? std::string("plus")
                                     : c == '.' ? std::string("_")
                                                : std::string(1, c);
                           }
                           return name;
                         });

TEST(CameraModelTest, NamesIdsAndParameterCountsAreColmaps) {
  const std::vector<std::tuple<int, std::string, int>> colmap = {
      {0, "SIMPLE_PINHOLE", 3},
      {1, "PINHOLE", 4},
      {2, "SIMPLE_RADIAL", 4},
      {3, "RADIAL", 5},
      {4, "OPENCV", 8},
      {5, "OPENCV_FISHEYE", 8},
      {6, "FULL_OPENCV", 12},
      {7, "FOV", 5},
      {8, "SIMPLE_RADIAL_FISHEYE", 4},
      {9, "RADIAL_FISHEYE", 5},
      {10, "THIN_PRISM_FISHEYE", 12}};
  ASSERT_EQ(AllCameraModels().size(), colmap.size());
  for (const auto& [id, name, count] : colmap) {
    const CameraModelInfo& info =
        GetCameraModelInfo(static_cast<CameraModelId>(id));
    EXPECT_EQ(info.name, name);
    EXPECT_EQ(info.num_params, count);
    EXPECT_EQ(CameraModelFromName(name), static_cast<CameraModelId>(id));
    EXPECT_EQ(CameraModelFromId(id), static_cast<CameraModelId>(id));
  }
  EXPECT_FALSE(CameraModelFromName("opencv").has_value());
  EXPECT_FALSE(CameraModelFromId(11).has_value());
  EXPECT_FALSE(CameraModelFromId(-1).has_value());
}

// The parameter order and formulas, written out independently from COLMAP's
// models.h for one point each.
TEST(CameraModelTest, DistortionFormulasFollowColmapParameterOrder) {
  const double u = 0.3, v = -0.2;
  const double u2 = u * u, v2 = v * v, uv = u * v, r2 = u2 + v2;
  {
    const double fx = 800, fy = 805, cx = 320, cy = 240, k1 = -0.2, k2 = 0.05,
                 p1 = 1e-3, p2 = -2e-3;
    const Camera c =
        Make(CameraModelId::kOpenCV, {fx, fy, cx, cy, k1, k2, p1, p2});
    const double radial = k1 * r2 + k2 * r2 * r2;
    const double du = u * radial + 2 * p1 * uv + p2 * (r2 + 2 * u2);
    const double dv = v * radial + 2 * p2 * uv + p1 * (r2 + 2 * v2);
    const Eigen::Vector2d expected(fx * (u + du) + cx, fy * (v + dv) + cy);
    EXPECT_LT((c.PixelFromNormalized({u, v}) - expected).norm(), 1e-12);
  }
  {
    const double k[8] = {-0.2, 0.05, 1e-3, -2e-3, 0.01, 0.02, 0.003, 0.001};
    const Camera c = Make(
        CameraModelId::kFullOpenCV,
        {700, 710, 300, 200, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]});
    const double r4 = r2 * r2, r6 = r4 * r2;
    const double radial = (1 + k[0] * r2 + k[1] * r4 + k[4] * r6) /
                          (1 + k[5] * r2 + k[6] * r4 + k[7] * r6);
    const double du = u * radial + 2 * k[2] * uv + k[3] * (r2 + 2 * u2) - u;
    const double dv = v * radial + 2 * k[3] * uv + k[2] * (r2 + 2 * v2) - v;
    const Eigen::Vector2d expected(700 * (u + du) + 300, 710 * (v + dv) + 200);
    EXPECT_LT((c.PixelFromNormalized({u, v}) - expected).norm(), 1e-12);
  }
  {
    const double k[4] = {0.05, -0.01, 0.002, -0.0005};
    const Camera c = Make(CameraModelId::kOpenCVFisheye,
                          {250, 252, 320, 240, k[0], k[1], k[2], k[3]});
    const double r = std::sqrt(r2), theta = std::atan(r), t2 = theta * theta;
    const double thetad =
        theta * (1 + k[0] * t2 + k[1] * t2 * t2 + k[2] * t2 * t2 * t2 +
                 k[3] * t2 * t2 * t2 * t2);
    const Eigen::Vector2d expected(250 * (u * thetad / r) + 320,
                                   252 * (v * thetad / r) + 240);
    EXPECT_LT((c.PixelFromNormalized({u, v}) - expected).norm(), 1e-12);
  }
  {
    const double k[8] = {0.05, -0.01, 1e-3, -1e-3, 0.002, -0.0005, 1e-3, -2e-3};
    const Camera c = Make(
        CameraModelId::kThinPrismFisheye,
        {250, 250, 320, 240, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]});
    const double r = std::sqrt(r2), theta = std::atan(r);
    const double a = theta * u / r, b = theta * v / r;
    const double a2 = a * a, b2 = b * b, ab = a * b, s2 = a2 + b2;
    const double radial = k[0] * s2 + k[1] * s2 * s2 + k[4] * s2 * s2 * s2 +
                          k[5] * s2 * s2 * s2 * s2;
    const double da =
        a * radial + 2 * k[2] * ab + k[3] * (s2 + 2 * a2) + k[6] * s2;
    const double db =
        b * radial + 2 * k[3] * ab + k[2] * (s2 + 2 * b2) + k[7] * s2;
    const Eigen::Vector2d expected(250 * (a + da) + 320, 250 * (b + db) + 240);
    EXPECT_LT((c.PixelFromNormalized({u, v}) - expected).norm(), 1e-12);
  }
}

TEST(CameraModelTest, FisheyeRoundTripAtEightyDegreesOffAxis) {
  const double theta = 80.0 * M_PI / 180.0;
  for (const Case& c : StrongCases()) {
    if (!c.camera.info().fisheye) continue;
    for (int i = 0; i < 16; ++i) {
      const double phi = 2 * M_PI * i / 16;
      const Eigen::Vector3d dir(std::sin(theta) * std::cos(phi),
                                std::sin(theta) * std::sin(phi),
                                std::cos(theta));
      const std::optional<Eigen::Vector2d> pixel = c.camera.Project(dir * 2.5);
      ASSERT_TRUE(pixel.has_value()) << c.name << " phi " << phi;
      const UnprojectResult r = c.camera.Unproject(*pixel);
      ASSERT_TRUE(r.ok()) << c.name << ": " << ToString(r.status);
      EXPECT_LT((r.ray - dir).norm(), 1e-12) << c.name;
      EXPECT_NEAR(std::acos(r.ray.z()), theta, 1e-12) << c.name;
      EXPECT_LT((*c.camera.Project(r.ray) - *pixel).norm(),
                kRoundTripTolerancePx)
          << c.name;
    }
  }
}

TEST(CameraModelTest, PixelBeyondTheFoldIsReportedNotReturned) {
  // x_d = x (1 - 0.4 r^2) peaks at r_d = 0.609: with f = 300 the corners sit
  // at r_d = 1.33, where no ray maps.
  const Camera camera =
      Make(CameraModelId::kSimpleRadial, {300, 320, 240, -0.4});
  const UnprojectResult corner = camera.Unproject({0, 0});
  EXPECT_FALSE(corner.ok());
  EXPECT_EQ(corner.status, UnprojectStatus::kOutsideDomain);
  EXPECT_EQ(corner.ray, Eigen::Vector3d::Zero());
  EXPECT_TRUE(camera.Unproject({320, 240}).ok());
  EXPECT_TRUE(camera.Unproject({400, 300}).ok());

  const RoundTripStats stats = MeasureRoundTrip(camera, 64, 48);
  EXPECT_GT(stats.failures, 0);
  EXPECT_LT(stats.failures, stats.samples);
  EXPECT_LT(stats.max_error_px,
            kRoundTripTolerancePx);  // what does come back is exact

  // A point past the fold (r = 1.2 > 0.913) would land back inside the
  // image: Project refuses it.
  EXPECT_FALSE(camera.Project({1.2, 0.0, 1.0}).has_value());
  EXPECT_TRUE(camera.Project({0.5, 0.0, 1.0}).has_value());
}

TEST(CameraModelTest, InvalidAndOverflowingPixelsAreReported) {
  const Camera camera =
      Make(CameraModelId::kOpenCV, {800, 800, 320, 240, 0.4, 0.1, 0, 0});
  EXPECT_EQ(camera.Unproject({std::nan(""), 10}).status,
            UnprojectStatus::kInvalidInput);
  EXPECT_EQ(camera.Unproject({INFINITY, 10}).status,
            UnprojectStatus::kInvalidInput);
  const UnprojectResult huge = camera.Unproject({1e300, 1e300});
  EXPECT_FALSE(huge.ok());
  EXPECT_EQ(huge.status, UnprojectStatus::kNotConverged);
}

TEST(CameraModelTest, FisheyePixelBeyondNinetyDegreesIsOutsideDomain) {
  // Equidistant fisheye: 100 degrees off-axis sits at r_d = 1.745 rad.
  const Camera camera =
      Make(CameraModelId::kOpenCVFisheye, {100, 100, 320, 240, 0, 0, 0, 0});
  const UnprojectResult r = camera.Unproject({320 + 100 * 1.745, 240});
  EXPECT_EQ(r.status, UnprojectStatus::kOutsideDomain);
  const UnprojectResult ok = camera.Unproject({320 + 100 * 1.5, 240});
  ASSERT_TRUE(ok.ok());
  EXPECT_NEAR(std::acos(ok.ray.z()), 1.5, 1e-12);
}

TEST(CameraModelTest, PointsBehindTheCameraDoNotProject) {
  const Camera camera = Make(CameraModelId::kPinhole, {500, 500, 320, 240});
  EXPECT_FALSE(camera.Project({0, 0, -1}).has_value());
  EXPECT_FALSE(camera.Project({1, 0, 0}).has_value());
  EXPECT_FALSE(camera.Project({0, 0, std::nan("")}).has_value());
  const Eigen::Vector2d center = *camera.Project({0, 0, 2});
  EXPECT_EQ(center, Eigen::Vector2d(320, 240));
}

TEST(CameraModelTest, CheckNamesTheWrongField) {
  Camera camera = Make(CameraModelId::kOpenCV, {800, 800, 320, 240, 0.1});
  try {
    camera.Check("cameras.txt");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "cameras.txt");
    EXPECT_EQ(e.field(), "params");
    EXPECT_NE(std::string(e.what()).find(
                  "expects 8 (fx, fy, cx, cy, k1, k2, p1, p2)"),
              std::string::npos);
  }
  camera.params = {800, 800, 320, 240, 0.1, 0, 0, std::nan("")};
  EXPECT_THROW(camera.Check(), Error);
  camera.params = {-800, 800, 320, 240, 0, 0, 0, 0};
  EXPECT_THROW(camera.Check(), Error);
  camera.params = {800, 800, 320, 240, 0, 0, 0, 0};
  camera.width = 0;
  EXPECT_THROW(camera.Check(), Error);
}

TEST(CameraJsonTest, RoundTripAndTypeErrors) {
  const Camera camera = Make(CameraModelId::kOpenCV,
                             {800, 810, 322, 238, -0.4, 0.05, 1e-3, -2e-3});
  const Camera back = CameraFromJson(CameraToJson(camera), "mem");
  EXPECT_EQ(back.model_id, camera.model_id);
  EXPECT_EQ(back.width, camera.width);
  EXPECT_EQ(back.params, camera.params);

  Json wrong = CameraToJson(camera);
  wrong["width"] = "640";
  try {
    CameraFromJson(wrong, "cam.json");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "cam.json: field 'width' = \"640\": expected an integer, got a string");
  }
  Json unknown = CameraToJson(camera);
  unknown["model"] = "KANNALA";
  EXPECT_THROW(CameraFromJson(unknown, "cam.json"), Error);
}

}  // namespace
}  // namespace pano4d
