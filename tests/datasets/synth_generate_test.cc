#include "src/datasets/synth_generate.h"

#include <cstring>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/npy.h"
#include "src/datasets/dataset.h"
#include "src/datasets/synth_cameras.h"
#include "src/datasets/synth_render.h"
#include "tests/support/test_files.h"

namespace pano4d::synth {
namespace {

std::map<std::string, std::vector<std::uint8_t>> Files(
    const std::filesystem::path& root) {
  std::map<std::string, std::vector<std::uint8_t>> files;
  for (const auto& entry :
       std::filesystem::recursive_directory_iterator(root)) {
    if (entry.is_regular_file()) {
      files[std::filesystem::relative(entry.path(), root).string()] =
          ReadFileBytes(entry.path());
    }
  }
  return files;
}

TEST(SynthGenerateTest, TinySceneIsACompleteDyCheckDataset) {
  testing::TempDir dir;
  const SynthSummary summary =
      GenerateSynthScene({"tiny", 0, false}, dir.path());
  EXPECT_GT(summary.val_pixels, 0);
  const Dataset dataset = LoadDataset(dir.path(), 2);
  ASSERT_EQ(dataset.train.size(), 8u);
  ASSERT_EQ(dataset.val.size(), 16u);
  for (const auto* split : {&dataset.train, &dataset.val}) {
    for (const DatasetFrame& f : *split) {
      EXPECT_TRUE(std::filesystem::exists(f.rgb)) << f.id;
      EXPECT_FALSE(f.depth.empty()) << f.id;
      EXPECT_EQ(f.camera.camera.width, 64);
    }
  }
  for (const DatasetFrame& f : dataset.val)
    EXPECT_FALSE(f.covisible.empty()) << f.id;

  const Image rgb = ReadImage(dataset.val[0].rgb);
  EXPECT_EQ(rgb.width(), 64);
  EXPECT_EQ(rgb.height(), 48);
  const NpyArray depth = ReadNpy(dataset.train[0].depth);
  EXPECT_EQ(depth.shape, (std::vector<std::int64_t>{48, 64, 1}));
  EXPECT_EQ(depth.descr(), "<f4");
  const Json meta = ReadJson(dir / "synth.json");
  EXPECT_EQ(meta["preset"], "tiny");
  EXPECT_NEAR(meta["covisibility"]["unseen_fraction"].get<double>(),
              summary.unseen_fraction, 1e-12);
  // Something moves in the dynamic variant.
  int dynamic = 0;
  for (const DatasetFrame& f : dataset.train) {
    dynamic +=
        cv::countNonZero(ReadMask(dir / "dynamic" / "2x" / (f.id + ".png")));
  }
  EXPECT_GT(dynamic, 0);
}

TEST(SynthGenerateTest, FilesReadBackAsTheCamerasAndImagesThatWereRendered) {
  testing::TempDir dir;
  GenerateSynthScene({"tiny", 0, false}, dir.path());
  const Dataset dataset = LoadDataset(dir.path(), 1);
  const Scene scene = BuildScene(0, false);
  const Camera intrinsics{
      CameraModelId::kPinhole, 128, 96, {115.2, 115.2, 64, 48}};
  const std::vector<PosedCamera> cameras =
      TrainingTrajectory(scene, intrinsics, 8, 0);
  for (int t : {0, 5}) {
    const PosedCamera& loaded = dataset.train[t].camera;
    EXPECT_LT((loaded.cam_from_world.ToMatrix() -
               cameras[t].cam_from_world.ToMatrix())
                  .cwiseAbs()
                  .maxCoeff(),
              1e-9);
    EXPECT_EQ(loaded.camera.params, cameras[t].camera.params);
    const RenderedFrame rendered =
        RenderFrame(scene, cameras[t], t / 7.0, true, false);
    const Image read = ReadImage(dataset.train[t].rgb);
    EXPECT_LE(cv::norm(read.mat(), rendered.rgb.mat(), cv::NORM_INF),
              0.5 / 255 + 1e-6);
    const NpyArray depth = ReadNpy(dataset.train[t].depth);
    EXPECT_EQ(
        std::memcmp(depth.data.data(), rendered.depth.data, depth.data.size()),
        0);
  }
}

TEST(SynthGenerateTest, SameSeedSameBytesOtherSeedOtherScene) {
  testing::TempDir a, b, c;
  GenerateSynthScene({"tiny", 7, false}, a.path());
  GenerateSynthScene({"tiny", 7, false}, b.path());
  GenerateSynthScene({"tiny", 8, false}, c.path());
  const auto files_a = Files(a.path());
  const auto files_b = Files(b.path());
  ASSERT_EQ(files_a.size(), files_b.size());
  EXPECT_GT(files_a.size(), 100u);
  for (const auto& [name, bytes] : files_a) {
    EXPECT_TRUE(bytes == files_b.at(name))
        << name << " differs between runs with the same seed";
  }
  EXPECT_FALSE(files_a.at("rgb/1x/0_00000.png") ==
               Files(c.path()).at("rgb/1x/0_00000.png"));
}

TEST(SynthGenerateTest, StaticVariantHasNoDynamicPixels) {
  testing::TempDir dir;
  GenerateSynthScene({"tiny", 0, true}, dir.path());
  for (const auto& entry :
       std::filesystem::directory_iterator(dir / "dynamic" / "1x")) {
    EXPECT_EQ(cv::countNonZero(ReadMask(entry.path())), 0) << entry.path();
  }
  EXPECT_EQ(ReadJson(dir / "synth.json")["static"], true);
}

TEST(SynthGenerateTest, VariedSceneRecordsItsLayoutAndIsAnotherScene) {
  testing::TempDir fixed, varied;
  GenerateSynthScene({"tiny", 5, false}, fixed.path());
  SynthOptions options{"tiny", 5, false};
  options.varied = true;
  GenerateSynthScene(options, varied.path());
  const Json j = ReadJson(varied / "synth.json");
  EXPECT_EQ(j["varied"], true);
  EXPECT_EQ(j["layout"], VariedLayout(5).ToJson());
  EXPECT_FALSE(ReadJson(fixed / "synth.json").contains("varied"));
  EXPECT_FALSE(Files(fixed.path()).at("rgb/1x/1_00000.png") ==
               Files(varied.path()).at("rgb/1x/1_00000.png"));
  // The same folder cannot silently hold the other kind of scene.
  EXPECT_FALSE(EnsureSynthScene(options, varied.path()));
  EXPECT_THROW(EnsureSynthScene({"tiny", 5, false}, varied.path()), Error);
}

TEST(SynthGenerateTest, UnknownPresetIsAnError) {
  testing::TempDir dir;
  EXPECT_THROW(GenerateSynthScene({"huge", 0, false}, dir.path()), Error);
}

}  // namespace
}  // namespace pano4d::synth
