#include "src/gs/scene4d.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/psnr.h"
#include "src/render/bench_scene.h"
#include "src/render/rasterizer.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

// A moving scene in front of BenchCamera: static and dynamic Gaussians
// from the bench scene, bases that turn and slide over the times.
GaussianScene MovingScene(int sh_degree) {
  const RasterCamera camera = BenchCamera(96, 72);
  GaussianScene scene;
  scene.statics = RandomViewFillingScene(400, camera, 3.f, 1);
  scene.dynamics = RandomViewFillingScene(120, camera, 3.f, 2);
  std::mt19937 rng(3);
  std::normal_distribution<float> normal;
  for (GaussianModel* m : {&scene.statics, &scene.dynamics}) {
    const std::vector<float> dc = m->sh;
    m->sh_degree = sh_degree;
    m->Resize(m->size());
    for (std::size_t i = 0; i < m->size(); ++i) {
      for (int c = 0; c < 3; ++c)
        m->sh[i * m->sh_coefficients() * 3 + c] = dc[i * 3 + c];
      for (int k = 3; k < m->sh_coefficients() * 3; ++k)
        m->sh[i * m->sh_coefficients() * 3 + k] = 0.1f * normal(rng);
      for (int j = 0; j < 3; ++j)
        m->log_scales[i * 3 + j] += 0.3f * normal(rng);
      for (int j = 0; j < 4; ++j) m->quats[i * 4 + j] = normal(rng);
    }
  }
  scene.num_times = 6;
  scene.canonical_time = 2;
  scene.bases.Reset(4, scene.num_times);
  for (float& v : scene.bases.rotations) v += 0.1f * normal(rng);
  for (float& v : scene.bases.translations) v = 0.2f * normal(rng);
  scene.logits.resize(scene.dynamics.size() * 4);
  for (float& v : scene.logits) v = 2.f * normal(rng);
  return scene;
}

double RenderPsnr(const GaussianModel& a, const GaussianModel& b) {
  const RasterCamera camera = BenchCamera(96, 72);
  Rasterizer r;
  RenderOutput ra, rb;
  r.Render(a, camera, {}, &ra);
  r.Render(b, camera, {}, &rb);
  double se = 0;
  for (std::size_t i = 0; i < ra.rgb.size(); ++i)
    se += (ra.rgb[i] - rb.rgb[i]) * (ra.rgb[i] - rb.rgb[i]);
  return PsnrFromMse(se / ra.rgb.size());
}

TEST(Scene4dTest, RoundTripRendersEveryTimeAsTheScene) {
  const GaussianScene scene = MovingScene(1);
  const EncodedScene4d encoded = EncodeScene4d(scene, {{"note", "x"}});
  Json extras;
  const GaussianScene back =
      DecodeScene4d(encoded.header, encoded.binary, "mem", &extras);
  EXPECT_EQ(extras["note"], "x");
  ASSERT_EQ(back.statics.size(), scene.statics.size());
  ASSERT_EQ(back.dynamics.size(), scene.dynamics.size());
  EXPECT_EQ(back.num_times, 6);
  EXPECT_EQ(back.canonical_time, 2);
  EXPECT_EQ(back.bases.num_bases, 4);
  EXPECT_EQ(back.statics.sh_degree, 1);
  // Means and bases are float32: exact.
  EXPECT_EQ(back.statics.means, scene.statics.means);
  EXPECT_EQ(back.bases.translations, scene.bases.translations);
  GaussianModel posed, posed_back;
  for (int t = 0; t < scene.num_times; ++t) {
    scene.ComposeAt(t, &posed);
    back.ComposeAt(t, &posed_back);
    double worst = 0;
    for (std::size_t i = 0; i < posed.means.size(); ++i)
      worst = std::max(worst,
                       double(std::abs(posed.means[i] - posed_back.means[i])));
    // float16 logits move a blended mean by well under a millimetre at a
    // basis translation of 0.2.
    const double psnr = RenderPsnr(posed, posed_back);
    std::printf("time %d: worst mean error %.2g, render PSNR %.1f dB\n", t,
                worst, psnr);
    EXPECT_LT(worst, 2e-3) << "time " << t;
    EXPECT_GT(psnr, 45.0) << "time " << t;
  }
}

TEST(Scene4dTest, IsSmallerThanAPlyPerTime) {
  const GaussianScene scene = MovingScene(0);
  const EncodedScene4d encoded = EncodeScene4d(scene);
  // A 3DGS PLY holds 17 floats per Gaussian at degree 0, once per time.
  const double ply_bytes = 17.0 * 4 * scene.size() * scene.num_times;
  EXPECT_LT(encoded.binary.size() * 5.0, ply_bytes);
  for (const auto& [name, a] : encoded.header["statics"]["arrays"].items())
    EXPECT_EQ(a["offset"].get<std::size_t>() % 4, 0u) << name;
}

TEST(Scene4dTest, AStaticSceneHasNoBases) {
  GaussianScene scene = MovingScene(0);
  scene.dynamics = GaussianModel();
  scene.logits.clear();
  scene.bases = MotionBases();
  scene.num_times = 1;
  scene.canonical_time = 0;
  const EncodedScene4d encoded = EncodeScene4d(scene);
  const GaussianScene back = DecodeScene4d(encoded.header, encoded.binary, "m");
  EXPECT_FALSE(back.has_motion());
  EXPECT_EQ(back.statics.size(), scene.statics.size());
}

TEST(Scene4dTest, RefusesNonFiniteValues) {
  GaussianScene scene = MovingScene(0);
  scene.dynamics.log_scales[5] = std::numeric_limits<float>::quiet_NaN();
  try {
    EncodeScene4d(scene);
    FAIL() << "a NaN was encoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dynamics.log_scales[5]"),
              std::string::npos)
        << e.what();
  }
}

// A zero quaternion (a corrupt or hand-made file) has no rotation: it must
// not reach an exported PLY or a render.
TEST(Scene4dTest, RefusesAZeroQuaternion) {
  GaussianScene scene = MovingScene(0);
  std::fill_n(scene.statics.quats.begin() + 4 * 7, 4, 0.0f);
  try {
    EncodeScene4d(scene);
    FAIL() << "a zero quaternion was encoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("statics.quats[7]"),
              std::string::npos)
        << e.what();
  }
}

TEST(Scene4dTest, RefusesATruncatedBinaryAndAnotherFormat) {
  const EncodedScene4d encoded = EncodeScene4d(MovingScene(0));
  const std::string cut = encoded.binary.substr(0, encoded.binary.size() / 2);
  EXPECT_THROW(
      {
        try {
          DecodeScene4d(encoded.header, cut, "scene4d.json");
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("binary_bytes"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      Error);
  // A header whose array points past the end of the binary.
  Json header = encoded.header;
  header["bases"]["arrays"]["rotations"]["offset"] = encoded.binary.size() - 8;
  EXPECT_THROW(DecodeScene4d(header, encoded.binary, "scene4d.json"), Error);
  header = encoded.header;
  header["format"] = "something-else";
  EXPECT_THROW(DecodeScene4d(header, encoded.binary, "scene4d.json"), Error);
}

TEST(Scene4dTest, FilesRoundTrip) {
  testing::TempDir dir;
  const GaussianScene scene = MovingScene(0);
  const std::uint64_t bytes = WriteScene4d(dir.path() / "out", scene);
  EXPECT_EQ(bytes,
            std::filesystem::file_size(dir.path() / "out" / kScene4dBinary) +
                std::filesystem::file_size(dir.path() / "out" / kScene4dJson));
  const GaussianScene back = ReadScene4d(dir.path() / "out");
  EXPECT_EQ(back.statics.means, scene.statics.means);
}

}  // namespace
}  // namespace pano4d
