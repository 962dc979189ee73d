#include "evaluation/evaluate.h"

#include <cmath>
#include <random>
#include <regex>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/file.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/datasets/synth_generate.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

const std::filesystem::path kMeta =
    std::filesystem::path(PANO4D_SOURCE_DIR) / "datasets_meta";

// The tiny synthetic scene, and "renders" that are its 2x validation
// frames with seeded noise (so every metric is finite and below perfect).
struct Fixture {
  testing::TempDir dir;
  Dataset dataset;
  std::filesystem::path renders;
  Fixture() {
    synth::GenerateSynthScene({"tiny", 0, false}, dir / "scene");
    dataset = LoadDataset(dir / "scene", 2);
    renders = dir / "renders";
    std::mt19937 rng(1);
    std::normal_distribution<float> noise(0.0f, 0.03f);
    for (const DatasetFrame& f : dataset.val) {
      Image image = ReadImage(f.rgb);
      for (int y = 0; y < image.height(); ++y) {
        for (int x = 0; x < image.width(); ++x) {
          for (int c = 0; c < 3; ++c) image.at(x, y)[c] += noise(rng);
        }
      }
      WriteImage(renders / (f.id + ".png"), image);
    }
  }
};

TEST(EvaluateTest, ScoresEveryFrameWithMaskedAndUnseenMetrics) {
  Fixture fx;
  const EvaluationResult r = EvaluateRenders(fx.dataset, fx.renders, {});
  ASSERT_EQ(r.frames.size(), 16u);
  double psnr_sum = 0;
  for (const FrameMetrics& m : r.frames) {
    ASSERT_TRUE(m.values[0].has_value());
    psnr_sum += *m.values[0];
    EXPECT_GT(*m.values[0], 20.0);
    EXPECT_LT(*m.values[0], 40.0);
    EXPECT_GE(m.covisible_fraction, 0.0);
    EXPECT_FALSE(m.values[2].has_value());  // LPIPS: n/a
  }
  EXPECT_NEAR(*r.mean[0], psnr_sum / 16, 1e-12);  // a plain mean over frames
  for (const char* key : {"psnr", "ssim", "mpsnr", "mssim", "upsnr", "ussim",
                          "mssim_strict", "ussim_strict"}) {
    const auto k =
        std::find(kMetricKeys.begin(), kMetricKeys.end(), std::string(key)) -
        kMetricKeys.begin();
    EXPECT_TRUE(r.mean[k].has_value()) << key;
  }
}

// The floor is the training frames' mean colour painted everywhere: renders
// that are that colour score exactly the floor, and the report sets the
// floor's row and uPSNR beside pano4d's.
TEST(EvaluateTest, TheMeanTrainingColourIsTheFloor) {
  Fixture fx;
  cv::Scalar sum = cv::Scalar::all(0);
  double pixels = 0;
  for (const DatasetFrame& f : fx.dataset.train) {
    const Image image = ReadImage(f.rgb);
    sum += cv::mean(image.mat()) * (image.width() * image.height());
    pixels += image.width() * image.height();
  }
  const EvaluationResult noisy = EvaluateRenders(fx.dataset, fx.renders, {});
  ASSERT_TRUE(noisy.floor);
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(noisy.floor->rgb[c], sum[c] / pixels, 1e-9) << c;
  const auto constant = fx.dir / "constant";
  for (const DatasetFrame& f : fx.dataset.val) {
    const Image truth = ReadImage(f.rgb);
    Image image(truth.width(), truth.height());
    image.mat().setTo(sum / pixels);
    WriteImage(constant / (f.id + ".png"), image);
  }
  const EvaluationResult flat = EvaluateRenders(fx.dataset, constant, {});
  for (std::size_t k = 0; k < kNumMetrics; ++k) {
    ASSERT_EQ(flat.mean[k].has_value(), flat.floor->mean[k].has_value())
        << kMetricKeys[k];
    // The PNG rounds the colour to 8 bits where the floor's constant is
    // quantised as a render is (QuantizeForMetrics): a few hundredths of a
    // dB apart.
    if (flat.mean[k]) {
      EXPECT_NEAR(*flat.mean[k], *flat.floor->mean[k], 0.05) << kMetricKeys[k];
    }
  }
  // The noisy renders are far above a constant colour.
  EXPECT_GT(*noisy.mean[6], *noisy.floor->mean[6] + 5);  // upsnr
  const std::string markdown = WriteEvaluation(noisy, fx.dir / "m", kMeta);
  EXPECT_NE(markdown.find("| mean training colour (floor) |"),
            std::string::npos);
  EXPECT_NE(markdown.find("uPSNR against the floor of the mean training "
                          "colour: "),
            std::string::npos);
  const Json json = ReadJson(fx.dir / "m" / "metrics.json");
  EXPECT_NEAR(json["mean_colour_floor"]["mean"]["upsnr"].get<double>(),
              *noisy.floor->mean[6], 1e-9);
}

TEST(EvaluateTest, JsonMarkdownAndCsvAgree) {
  Fixture fx;
  const EvaluationResult r = EvaluateRenders(fx.dataset, fx.renders, {});
  const auto out = fx.dir / "metrics";
  const std::string markdown = WriteEvaluation(r, out, kMeta);
  const Json json = ReadJson(out / "metrics.json");
  for (const char* key : kMetricKeys)
    ASSERT_TRUE(json["mean"].contains(key)) << key;
  EXPECT_TRUE(json["mean"]["lpips"].is_null());
  EXPECT_EQ(json["frames"], 16);

  // The pano4d row of the Markdown table shows the JSON's means.
  std::smatch row;
  ASSERT_TRUE(std::regex_search(markdown, row,
                                std::regex(R"(\| pano4d \|([^\n]*)\n)")));
  std::vector<std::string> cells;
  std::stringstream stream(row[1].str());
  for (std::string cell; std::getline(stream, cell, '|');) {
    cells.push_back(std::regex_replace(cell, std::regex(R"(^\s+|\s+$)"), ""));
  }
  ASSERT_GE(cells.size(), 9u);
  for (std::size_t k = 0; k < 9; ++k) {
    const Json& v = json["mean"][kMetricKeys[k]];
    if (v.is_null()) {
      EXPECT_EQ(cells[k], "n/a") << kMetricKeys[k];
    } else {
      const double precision =
          std::string(kMetricKeys[k]).find("psnr") != std::string::npos
              ? 0.005
              : 0.0005;
      EXPECT_NEAR(std::stod(cells[k]), v.get<double>(), precision)
          << kMetricKeys[k];
    }
  }
  // The paper's rows sit beside pano4d's.
  EXPECT_NE(markdown.find("PanoGaussian (Ours) (paper, mean) | 18.71"),
            std::string::npos)
      << markdown;
  // One CSV line per frame plus the header.
  const std::string csv = ReadTextFile(out / "per_frame.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 17);
}

// A scene's published rows come from the per-scene sources and sit apart
// from the means over a benchmark's scenes.
TEST(EvaluateTest, PublishedRowsOfThisSceneApartFromTheMeans) {
  const Json nvidia = BenchmarkMeta(kMeta, "nvidia");
  ASSERT_TRUE(nvidia.is_object());
  const auto find = [](const std::vector<PublishedRow>& rows,
                       const std::string& method,
                       bool mean) -> const PublishedRow* {
    for (const PublishedRow& r : rows)
      if (r.method == method && r.mean == mean) return &r;
    return nullptr;
  };
  // The folder name decides the scene: "nvidia-balloon1" is Balloon1.
  const std::vector<PublishedRow> balloon1 =
      PublishedRows(nvidia, "nvidia-balloon1");
  const PublishedRow* dnerf = find(balloon1, "DynamicNeRF", false);
  ASSERT_NE(dnerf, nullptr);
  EXPECT_DOUBLE_EQ(*dnerf->values[0], 22.36);  // psnr
  EXPECT_DOUBLE_EQ(*dnerf->values[2], 0.104);  // lpips
  EXPECT_FALSE(dnerf->values[1].has_value());  // no SSIM published
  EXPECT_EQ(dnerf->source, "DynamicNeRF README");
  EXPECT_DOUBLE_EQ(*find(balloon1, "NSFF", false)->values[0], 21.96);
  // Means: the source's mean row and the paper's table.
  EXPECT_DOUBLE_EQ(*find(balloon1, "DynamicNeRF", true)->values[0], 26.10);
  ASSERT_NE(find(balloon1, "PanoGaussian (Ours)", true), nullptr);
  EXPECT_EQ(find(balloon1, "PanoGaussian (Ours)", false), nullptr);
  // Another scene gets its own rows; an unknown one only means.
  EXPECT_DOUBLE_EQ(
      *find(PublishedRows(nvidia, "Balloon2"), "DynamicNeRF", false)->values[0],
      27.06);
  for (const PublishedRow& r : PublishedRows(nvidia, "my-own-scene"))
    EXPECT_TRUE(r.mean) << r.method;
  EXPECT_TRUE(PublishedRows(Json(), "nvidia-balloon1").empty());

  EvaluationResult result;
  result.kind = "nvidia";
  result.scene = "nvidia-balloon1";
  result.mean[0] = 20.0;
  const std::string md = EvaluationMarkdown(result, balloon1, true);
  const auto scene = md.find("## This scene");
  const auto means = md.find("## Means over the benchmark's scenes");
  ASSERT_NE(scene, std::string::npos) << md;
  ASSERT_NE(means, std::string::npos) << md;
  const auto row = md.find("| DynamicNeRF (DynamicNeRF README) | 22.36 |");
  EXPECT_GT(row, scene);
  EXPECT_LT(row, means);
  EXPECT_GT(md.find("| PanoGaussian (Ours) (paper, mean) | 26.75 |"), means);
}

TEST(EvaluateTest, LpipsColumnsWithWeights) {
  // The narrow AlexNet-topology network of the LPIPS fixture stands in for
  // the real weights, which are not on these machines.
  Fixture fx;
  const EvaluationResult r = EvaluateRenders(
      fx.dataset, fx.renders,
      {"val", std::filesystem::path(PANO4D_SOURCE_DIR) / "tests/data/lpips"});
  for (std::size_t k : {2, 5, 8}) {  // lpips, mlpips, ulpips
    ASSERT_TRUE(r.mean[k].has_value()) << kMetricKeys[k];
    EXPECT_GT(*r.mean[k], 0.0);
    EXPECT_TRUE(std::isfinite(*r.mean[k]));
  }
}

TEST(EvaluateTest, MissingMismatchedAndNonFiniteRendersAreErrors) {
  Fixture fx;
  const auto victim = fx.renders / (fx.dataset.val[3].id + ".png");
  std::filesystem::remove(victim);
  try {
    EvaluateRenders(fx.dataset, fx.renders, {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "1 of 16 renders are missing (first: 1_00003.png)"),
              std::string::npos)
        << e.what();
  }
  WriteImage(victim, Image(10, 10));
  try {
    EvaluateRenders(fx.dataset, fx.renders, {});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), victim.string());
    EXPECT_EQ(e.field(), "size");
  }
  std::filesystem::remove(victim);
  Image nan_image = ReadImage(fx.dataset.val[3].rgb);
  nan_image.at(2, 2)[1] = std::nanf("");
  cv::imwrite((fx.renders / (fx.dataset.val[3].id + ".exr")).string(),
              nan_image.mat());
  EXPECT_THROW(EvaluateRenders(fx.dataset, fx.renders, {}), Error);
  EXPECT_THROW(EvaluateRenders(fx.dataset, fx.renders, {"test", {}}), Error);
  EXPECT_THROW(EvaluateRenders(fx.dataset, fx.renders, {"val", "alex.pth"}),
               Error);
}

}  // namespace
}  // namespace pano4d
