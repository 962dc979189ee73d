// pano4d's COLMAP model files against the real `colmap` (COLMAP 3.8): the
// bytes colmap writes when converting, and the counts model_analyzer prints.
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <numeric>
#include <random>
#include <regex>
#include <sstream>

#include <gtest/gtest.h>

#include "colmap_ext/model.h"
#include "colmap_ext/model_io_binary.h"
#include "colmap_ext/model_io_text.h"
#include "src/core/file.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

namespace fs = std::filesystem;

std::string FindColmap() {
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const fs::path candidate = fs::path(dir.empty() ? "." : dir) / "colmap";
    std::error_code error;
    if (fs::is_regular_file(candidate, error)) return candidate.string();
  }
  return "";
}

#define REQUIRE_COLMAP()                                                   \
  const std::string colmap = FindColmap();                                 \
  if (colmap.empty()) {                                                    \
    GTEST_SKIP() << "COLMAP MISSING: `colmap` is not on PATH; install "    \
                    "COLMAP 3.8 (apt-get install colmap) to compare with " \
                    "it";                                                  \
  }

struct CommandResult {
  int status = -1;
  std::string output;  // stdout and stderr
};

// colmap is a Qt application; without a display it needs the offscreen
// platform for commands that touch Qt, and it logs to stderr via glog.
CommandResult RunColmap(const std::string& colmap, const std::string& args,
                        const fs::path& log) {
  const std::string command = "QT_QPA_PLATFORM=offscreen GLOG_logtostderr=1 '" +
                              colmap + "' " + args + " > '" + log.string() +
                              "' 2>&1";
  CommandResult run;
  run.status = std::system(command.c_str());
  run.output = ReadTextFile(log);
  return run;
}

std::string Convert(const std::string& colmap, const fs::path& in,
                    const fs::path& out, const char* type,
                    const fs::path& log) {
  fs::create_directories(out);
  const CommandResult run = RunColmap(
      colmap,
      "model_converter --input_path '" + in.string() + "' --output_path '" +
          out.string() + "' --output_type " + type,
      log);
  return run.status == 0 ? "" : run.output;
}

// Quaternions that are exactly unit in floating point (integer quadruples
// with a^2 + b^2 + c^2 + d^2 = 64^2, over 64): COLMAP divides every qvec by
// its norm on reading and writing, and only these come through unchanged.
std::vector<Eigen::Vector4d> ExactUnitQuaternions() {
  std::vector<Eigen::Vector4d> result;
  for (int a = 0; a <= 64; ++a)
    for (int b = 0; b <= 64; ++b)
      for (int c = 0; c <= 64; ++c) {
        const int rest = 64 * 64 - a * a - b * b - c * c;
        const int d =
            static_cast<int>(std::lround(std::sqrt(std::max(0, rest))));
        if (rest >= 0 && d * d == rest && a % 3 != 0) {
          result.emplace_back(a / 64.0, -b / 64.0, c / 64.0, d / 64.0);
        }
      }
  return result;
}

// The model of the unit tests, with names COLMAP's text reader takes whole
// (it stops at the first space) and exactly unit qvecs.
ColmapModel BuildModel() {
  std::mt19937 rng(23);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> pixel(0.0, 4000.0);
  const std::vector<Eigen::Vector4d> unit = ExactUnitQuaternions();
  ColmapModel model;
  for (int m = 0; m < 11; ++m) {
    ColmapCamera& camera = model.cameras.emplace_back();
    camera.camera_id = 1 + 2 * m;
    camera.model_id = m;
    camera.width = 4000 - m;
    camera.height = 3000 + m;
    camera.params.resize(GetCameraModelInfo(CameraModelId(m)).num_params);
    for (double& p : camera.params) p = normal(rng) * std::pow(10.0, m - 4);
  }
  for (int i = 0; i < 40; ++i) {
    ColmapImage& image = model.images.emplace_back();
    image.image_id = 3 * i + 1;
    image.qvec = unit[(37 * i) % unit.size()];
    image.tvec = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    image.camera_id = model.cameras[i % 11].camera_id;
    image.name = "seq/frame_" + std::to_string(1000 + i) + ".jpg";
  }
  for (int k = 0; k < 300; ++k) {
    ColmapPoint3D& point = model.points3D.emplace_back();
    point.point3D_id = 1 + 2 * k;
    point.xyz = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)) * 5;
    point.rgb = {static_cast<std::uint8_t>(k), 128, 3};
    point.error = std::abs(normal(rng));
    const int length = k % 25 == 0 ? 30 : 2 + k % 3;
    for (int e = 0; e < length; ++e) {
      const int i = (k + 7 * e) % 40;
      ColmapImage& image = model.images[i % 4 == 0 ? i + 1 : i];
      if (e % 2 == 0) image.points2D.push_back({{pixel(rng), pixel(rng)}});
      image.points2D.push_back({{pixel(rng), pixel(rng)}, point.point3D_id});
      point.track.push_back({image.image_id, static_cast<std::uint32_t>(
                                                 image.points2D.size() - 1)});
    }
  }
  model.BuildIndex();
  return model;
}

// COLMAP writes in its hash maps' order, which the conversion changes; to
// compare bytes, our lists take the order of COLMAP's file.
template <typename T, typename GetId>
void OrderLike(std::vector<T>& list, const std::vector<T>& reference,
               const GetId& id) {
  std::unordered_map<std::uint64_t, std::size_t> rank;
  for (std::size_t i = 0; i < reference.size(); ++i) rank[id(reference[i])] = i;
  // Sorted by index: GCC 12's std::stable_sort buffer ignores the
  // over-alignment of the Eigen members.
  std::vector<std::size_t> order(list.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) {
                     return rank.at(id(list[a])) < rank.at(id(list[b]));
                   });
  std::vector<T> sorted;
  for (std::size_t i : order) sorted.push_back(list[i]);
  list = std::move(sorted);
}

void OrderLike(ColmapModel& model, const ColmapModel& reference) {
  OrderLike(model.cameras, reference.cameras,
            [](const ColmapCamera& c) { return c.camera_id; });
  OrderLike(model.images, reference.images,
            [](const ColmapImage& i) { return i.image_id; });
  OrderLike(model.points3D, reference.points3D,
            [](const ColmapPoint3D& p) { return p.point3D_id; });
  model.BuildIndex();
}

void ExpectSameFiles(const fs::path& ours, const fs::path& colmap,
                     const char* extension) {
  for (const char* name : {"cameras", "images", "points3D"}) {
    const std::string file = std::string(name) + extension;
    const std::vector<std::uint8_t> a = ReadFileBytes(ours / file);
    const std::vector<std::uint8_t> b = ReadFileBytes(colmap / file);
    EXPECT_EQ(a.size(), b.size()) << file;
    EXPECT_TRUE(a == b) << file << " differs from COLMAP's";
  }
}

TEST(ModelColmapTest, TextWriterMatchesColmapsConversion) {
  REQUIRE_COLMAP();
  testing::TempDir dir;
  ColmapModel model = BuildModel();
  ASSERT_NO_THROW(model.Check());
  WriteModel(model, dir / "bin", ColmapFormat::kBinary);
  ASSERT_EQ(
      Convert(colmap, dir / "bin", dir / "colmap_txt", "TXT", dir / "log.txt"),
      "");
  const ColmapModel colmap_text = ReadModel(dir / "colmap_txt");
  ASSERT_EQ(colmap_text.points3D.size(), model.points3D.size());
  OrderLike(model, colmap_text);
  WriteModel(model, dir / "ours_txt", ColmapFormat::kText);
  ExpectSameFiles(dir / "ours_txt", dir / "colmap_txt", ".txt");
  // Reading COLMAP's text and writing it again changes nothing either.
  WriteModel(colmap_text, dir / "rewritten", ColmapFormat::kText);
  ExpectSameFiles(dir / "rewritten", dir / "colmap_txt", ".txt");
}

TEST(ModelColmapTest, BinaryWriterMatchesColmapsConversion) {
  REQUIRE_COLMAP();
  testing::TempDir dir;
  ColmapModel model = BuildModel();
  WriteModel(model, dir / "txt", ColmapFormat::kText);
  ASSERT_EQ(
      Convert(colmap, dir / "txt", dir / "colmap_bin", "BIN", dir / "log.txt"),
      "");
  ColmapModel text = ReadModel(dir / "txt");
  const ColmapModel colmap_binary = ReadModel(dir / "colmap_bin");
  OrderLike(text, colmap_binary);
  WriteModel(text, dir / "ours_bin", ColmapFormat::kBinary);
  ExpectSameFiles(dir / "ours_bin", dir / "colmap_bin", ".bin");
}

TEST(ModelColmapTest, EdgeValuesMatchColmap) {
  REQUIRE_COLMAP();
  testing::TempDir dir;
  ColmapModel model;
  model.cameras.push_back({4, 1, 1, 1, {1e-320, -0.0, INFINITY, 1e308}});
  ColmapImage& image = model.images.emplace_back();
  image.image_id = 9;
  image.camera_id = 4;
  image.tvec = {std::numeric_limits<double>::quiet_NaN(), -1e-7, 123456789.0};
  image.points2D.push_back({{0.1, 0.2}});  // no 3D point at all
  model.points3D.push_back({2, {-0.0, 1e-310, 3}, {255, 0, 7}, 0.0, {}});
  WriteModel(model, dir / "bin", ColmapFormat::kBinary);
  ASSERT_EQ(
      Convert(colmap, dir / "bin", dir / "colmap_txt", "TXT", dir / "log.txt"),
      "");
  WriteModel(model, dir / "ours_txt", ColmapFormat::kText);
  ExpectSameFiles(dir / "ours_txt", dir / "colmap_txt", ".txt");
}

// The number after "Label:" in model_analyzer's log, or -1.
double Reported(const std::string& output, const std::string& label) {
  const std::regex pattern(label + ": ([0-9.]+)");
  std::smatch match;
  if (!std::regex_search(output, match, pattern)) return -1;
  return std::stod(match[1]);
}

TEST(ModelColmapTest, ModelAnalyzerReportsOurCounts) {
  REQUIRE_COLMAP();
  testing::TempDir dir;
  ColmapModel model = BuildModel();
  // An observation of a point that is not in the model: COLMAP still counts
  // it, as pano4d does.
  model.images[1].points2D.push_back({{5.0, 5.0}, 999999});
  for (const ColmapFormat format :
       {ColmapFormat::kBinary, ColmapFormat::kText}) {
    const fs::path folder = dir / std::string(ToString(format));
    WriteModel(model, folder, format);
    const CommandResult run =
        RunColmap(colmap, "model_analyzer --path '" + folder.string() + "'",
                  dir / "log.txt");
    ASSERT_EQ(run.status, 0) << run.output;
    const ColmapModelStats stats = model.Stats();
    EXPECT_EQ(Reported(run.output, "Cameras"), stats.cameras) << run.output;
    EXPECT_EQ(Reported(run.output, "Images"), stats.images);
    EXPECT_EQ(Reported(run.output, "Registered images"),
              stats.registered_images);
    EXPECT_EQ(Reported(run.output, "Points"), stats.points3D);
    EXPECT_EQ(Reported(run.output, "Observations"), stats.observations);
    // Printed with 6 decimals.
    EXPECT_NEAR(Reported(run.output, "Mean track length"),
                stats.mean_track_length, 5e-7);
    EXPECT_NEAR(Reported(run.output, "Mean observations per image"),
                stats.mean_observations_per_image, 5e-7);
  }
}

}  // namespace
}  // namespace pano4d
