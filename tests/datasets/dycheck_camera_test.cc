#include "src/datasets/dycheck_camera.h"

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"

namespace pano4d {
namespace {

Json PaperWindmillCamera() {
  // camera/0_00000.json of DyCheck's paper-windmill, as shipped.
  return ParseJson(R"({
    "focal_length": 719.9471435546875, "image_size": [720, 960],
    "orientation": [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]],
    "pixel_aspect_ratio": 1.0, "position": [0.0, 4.656612873077393e-10, 0.0],
    "principal_point": [358.8895263671875, 484.92236328125],
    "radial_distortion": [0.0, 0.0, 0.0], "skew": 0.0, "tangential_distortion": [0.0, 0.0]})",
                   "0_00000.json");
}

TEST(DyCheckCameraTest, ReadsNerfiesConvention) {
  const PosedCamera c =
      DyCheckCameraFromJson(PaperWindmillCamera(), "0_00000.json");
  EXPECT_EQ(c.camera.model_id, CameraModelId::kPinhole);
  EXPECT_EQ(c.camera.width, 720);
  EXPECT_EQ(c.camera.height, 960);
  EXPECT_DOUBLE_EQ(c.camera.focal_x(), 719.9471435546875);
  // orientation = diag(1, -1, -1) world-to-camera: a point 2 m along world -z
  // is 2 m in front of the camera, at the principal point.
  const Eigen::Vector2d pixel = *c.Project({0, 0, -2});
  EXPECT_NEAR(pixel.x(), 358.8895263671875, 1e-9);
  EXPECT_NEAR(pixel.y(), 484.92236328125, 1e-6);
  EXPECT_LT((c.Center() - Eigen::Vector3d(0, 4.656612873077393e-10, 0)).norm(),
            1e-15);
}

TEST(DyCheckCameraTest, DistortionMapsToColmapModels) {
  Json json = PaperWindmillCamera();
  json["radial_distortion"] = {0.1, -0.05, 0.0};
  json["tangential_distortion"] = {1e-3, -2e-3};
  json["pixel_aspect_ratio"] = 1.01;
  const PosedCamera opencv = DyCheckCameraFromJson(json, "c.json");
  EXPECT_EQ(opencv.camera.model_id, CameraModelId::kOpenCV);
  EXPECT_DOUBLE_EQ(opencv.camera.focal_y(), 719.9471435546875 * 1.01);
  json["radial_distortion"] = {0.1, -0.05, 0.02};
  const PosedCamera full = DyCheckCameraFromJson(json, "c.json");
  ASSERT_EQ(full.camera.model_id, CameraModelId::kFullOpenCV);

  // DyCheck's projection, written out: radial 1 + r2 (k1 + r2 (k2 + k3 r2)).
  const double x = 0.2, y = -0.1, r2 = x * x + y * y;
  const double radial = 1 + r2 * (0.1 + r2 * (-0.05 + 0.02 * r2));
  const double xd = x * radial + 2 * 1e-3 * x * y + -2e-3 * (r2 + 2 * x * x);
  const double yd = y * radial + 2 * -2e-3 * x * y + 1e-3 * (r2 + 2 * y * y);
  const Eigen::Vector2d expected(
      719.9471435546875 * xd + 358.8895263671875,
      719.9471435546875 * 1.01 * yd + 484.92236328125);
  EXPECT_LT((full.camera.PixelFromNormalized({x, y}) - expected).norm(), 1e-9);

  // And back to JSON with the same numbers.
  const PosedCamera back =
      DyCheckCameraFromJson(DyCheckCameraToJson(full), "c.json");
  EXPECT_EQ(back.camera.params, full.camera.params);
}

TEST(DyCheckCameraTest, RejectsWhatItCannotRepresent) {
  Json skewed = PaperWindmillCamera();
  skewed["skew"] = 0.5;
  EXPECT_THROW(DyCheckCameraFromJson(skewed, "c.json"), Error);
  Json sheared = PaperWindmillCamera();
  sheared["orientation"][0] = {1.0, 0.1, 0.0};
  try {
    DyCheckCameraFromJson(sheared, "c.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "orientation");
  }
  Json short_pp = PaperWindmillCamera();
  short_pp["principal_point"] = {1.0};
  EXPECT_THROW(DyCheckCameraFromJson(short_pp, "c.json"), Error);
  Json text = PaperWindmillCamera();
  text["focal_length"] = "720";
  EXPECT_THROW(DyCheckCameraFromJson(text, "c.json"), Error);
  const PosedCamera fisheye{
      Camera{CameraModelId::kOpenCVFisheye, 10, 10, {5, 5, 5, 5, 0, 0, 0, 0}},
      Rigid3d()};
  EXPECT_THROW(DyCheckCameraToJson(fisheye), Error);
}

}  // namespace
}  // namespace pano4d
