// The depth stage in process: a dataset's depth listed as it is, and
// another tool's depth maps aligned to the SfM points of a COLMAP
// workspace (here one built from the tiny synthetic scene's true cameras
// and depth, so that the right answer is known).
#include "src/pipeline/depth.h"
#include "src/geometry/depth_alignment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "colmap_ext/model.h"
#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "src/datasets/dataset.h"
#include "src/datasets/depth_map.h"
#include "src/datasets/synth_generate.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

// The external tool's depth: affine in the truth (scale and shift unknown
// to the stage), at half the frames' resolution.
constexpr double kToolScale = 0.5, kToolShift = -0.2;

class DepthStageTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    synth::SynthOptions s;
    s.preset = "tiny";
    synth::GenerateSynthScene(s, dir_->path() / "tiny");
  }
  static void TearDownTestSuite() { delete dir_; }

  // A COLMAP workspace of the dataset's training frames: their images,
  // cameras and, as sparse points, every 8th pixel of their true depth
  // (one image each); and the external tool's maps in WS/tool.
  static Workspace ColmapWorkspace(const std::string& name) {
    const Workspace ws(dir_->path() / name);
    const Dataset d = LoadDataset(dir_->path() / "tiny", 2);
    ColmapModel model;
    std::uint64_t next_point = 1;
    for (const DatasetFrame& f : d.train) {
      const auto id = static_cast<std::uint32_t>(model.images.size() + 1);
      model.cameras.push_back(FromCamera(id, f.camera.camera));
      ColmapImage image;
      image.image_id = id;
      image.camera_id = id;
      image.name = f.id + ".png";
      image.SetCamFromWorld(f.camera.cam_from_world);
      const cv::Mat depth = ReadDepth(f);
      for (int y = 4; y < depth.rows; y += 8)
        for (int x = 4; x < depth.cols; x += 8) {
          const float z = depth.at<float>(y, x);
          if (!(z > 0)) continue;
          const Eigen::Vector2d pixel(x + 0.5, y + 0.5);
          const Eigen::Vector3d ray = f.camera.camera.Unproject(pixel).ray;
          ColmapPoint3D p;
          p.point3D_id = next_point++;
          p.xyz = f.camera.cam_from_world.Inverse() * (ray / ray.z() * z);
          p.track.push_back(
              {id, static_cast<std::uint32_t>(image.points2D.size())});
          image.points2D.push_back({pixel, p.point3D_id});
          model.points3D.push_back(p);
        }
      model.images.push_back(image);
      fs::create_directories(ws.images());
      fs::copy_file(f.rgb, ws.images() / image.name);
      cv::Mat tool;
      cv::resize(depth, tool, cv::Size(depth.cols / 2, depth.rows / 2), 0, 0,
                 cv::INTER_NEAREST);
      tool = tool * kToolScale + kToolShift;
      WriteDepthMap(ws.root() / "tool" / (f.id + ".npy"), tool);
    }
    model.BuildIndex();
    WriteModel(model, ws.sparse() / "0", ColmapFormat::kBinary);
    WriteJson(ws.sfm_json(), {{"model", "sparse/0"}, {"images", "images"}});
    return ws;
  }

  static testing::TempDir* dir_;
};
testing::TempDir* DepthStageTest::dir_ = nullptr;

TEST_F(DepthStageTest, ADatasetsDepthIsListedAsItIs) {
  const Workspace ws(dir_->path() / "listed");
  DepthOptions o;
  o.dataset = dir_->path() / "tiny";
  const DepthSummary s = RunDepth(ws, o);
  EXPECT_EQ(s.frames.depth_source, kDepthFromDataset);
  EXPECT_EQ(s.with_depth, static_cast<int>(s.frames.train.size()));
  EXPECT_EQ(s.frames.val.size(), 16u);
  const WorkspaceFrames read = ReadWorkspaceFrames(ws.root());
  ASSERT_EQ(read.train.size(), s.frames.train.size());
  const WorkspaceFrame& f = read.train.front();
  EXPECT_EQ(f.depth, ws.depth_map(f.name));
  const cv::Mat depth = ReadDepthMap(f.depth);
  EXPECT_EQ(depth.cols, f.camera.camera.width);
  EXPECT_GT(cv::countNonZero(depth), depth.total() / 2);
}

// Scale and shift are found per frame from the SfM points; the maps are
// brought to the frames' size; a missing map names the frame.
TEST_F(DepthStageTest, ExternalDepthIsAlignedToTheSparsePoints) {
  const Workspace ws = ColmapWorkspace("external");
  DepthOptions o;
  o.depth_dir = ws.root() / "tool";
  o.holdout = 4;
  const DepthSummary s = RunDepth(ws, o);
  EXPECT_EQ(s.frames.depth_source, kDepthFromExternal);
  EXPECT_EQ(s.frames.val.size(), 2u);  // frames 0 and 4 of 8
  EXPECT_EQ(s.with_depth, 6);
  const Json alignment = ReadJson(ws.depth() / "alignment.json");
  ASSERT_EQ(alignment.size(), 6u);
  for (const Json& a : alignment) {
    EXPECT_NEAR(a.at("scale").get<double>(), 1 / kToolScale, 1e-3) << a;
    EXPECT_NEAR(a.at("shift").get<double>(), -kToolShift / kToolScale, 1e-3)
        << a;
  }
  // The aligned map of a frame against its true depth, where both have it.
  const Dataset d = LoadDataset(dir_->path() / "tiny", 2);
  const WorkspaceFrame& f = s.frames.train.front();
  const DatasetFrame* truth = nullptr;
  for (const DatasetFrame& t : d.train)
    if (t.id == f.name) truth = &t;
  ASSERT_NE(truth, nullptr);
  const cv::Mat aligned = ReadDepthMap(f.depth), z = ReadDepth(*truth);
  ASSERT_EQ(aligned.size(), z.size());
  std::vector<double> relative;
  for (int y = 0; y < z.rows; ++y)
    for (int x = 0; x < z.cols; ++x) {
      const float a = aligned.at<float>(y, x), b = z.at<float>(y, x);
      if (a > 0 && b > 0) relative.push_back(std::abs(a - b) / b);
    }
  ASSERT_GT(relative.size(), z.total() / 2);
  // The half-resolution map upsampled (nearest) is off by its slope over a
  // pixel; a wrong scale or shift would be off everywhere.
  std::nth_element(relative.begin(), relative.begin() + relative.size() / 2,
                   relative.end());
  EXPECT_LT(relative[relative.size() / 2], 0.01);

  // A map with width and height swapped is refused, not stretched.
  const fs::path map = ws.root() / "tool" / (f.name + ".npy");
  const cv::Mat kept = ReadDepthMap(map);
  WriteDepthMap(map, kept.t());
  try {
    RunDepth(ws, o);
    FAIL() << "a transposed depth map was stretched";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), map.string()) << e.what();
    EXPECT_NE(std::string(e.what()).find("aspect ratio"), std::string::npos);
  }
  fs::remove(map);
  try {
    RunDepth(ws, o);
    FAIL() << "a frame without a depth map was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.value(), f.name);
  }
}

// A dataset without depth: stereo on its own cameras, bounded and checked
// by the sparse points of a model at the same factor; a model at another
// size is refused by name.
TEST_F(DepthStageTest, ADatasetWithoutDepthGetsStereoOnItsCameras) {
  const fs::path no_depth = dir_->path() / "no_depth";
  if (!fs::exists(no_depth)) {
    fs::copy(dir_->path() / "tiny", no_depth, fs::copy_options::recursive);
    fs::remove_all(no_depth / "depth");
  }
  const Workspace ws = ColmapWorkspace("dataset_stereo");
  DepthOptions o;
  o.dataset = no_depth;
  o.factor = 2;
  const DepthSummary s = RunDepth(ws, o);
  EXPECT_EQ(s.frames.depth_source, kDepthFromStereo);
  EXPECT_EQ(s.frames.dataset_factor, 2);
  EXPECT_EQ(s.frames.val.size(), 16u);  // the dataset's split, kept
  EXPECT_GT(s.with_depth, 0);
  const Json stereo = ReadJson(ws.depth() / "stereo.json");
  ASSERT_EQ(stereo.size(), static_cast<std::size_t>(s.with_depth));
  for (const Json& frame : stereo) {
    ASSERT_TRUE(frame.contains("check_median_relative_error")) << frame;
    EXPECT_LT(frame["check_median_relative_error"].get<double>(), 0.05)
        << frame;
  }
  o.factor = 1;
  try {
    RunDepth(ws, o);
    FAIL() << "a model at another size was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--factor"), std::string::npos)
        << e.what();
  }
}

// A dataset without depth, with learned-like priors (synth --priors: MiDaS-
// like disparity at 1x, twice the run's resolution): the moving pixels get
// the aligned learned depth, close to the truth; a frame without a
// disparity file keeps stereo only and is named; given motion masks
// replace the computed ones.
TEST_F(DepthStageTest, LearnedDepthFillsMovingPixelsAndStereoHoles) {
  const fs::path scene = dir_->path() / "tiny_priors";
  if (!fs::exists(scene)) {
    synth::SynthOptions so;
    so.preset = "tiny";
    so.priors = true;
    synth::GenerateSynthScene(so, scene);
    fs::remove_all(scene / "depth");
  }
  ASSERT_TRUE(fs::exists(scene / "disp" / "0_00003.npy"));
  ASSERT_TRUE(
      fs::exists(scene / "raft_exhaustive" / "0_00003.png_0_00004.png.npy"));
  fs::remove(scene / "disp" / "0_00005.npy");
  // A motion mask for frame 0_00002 only: the whole left half moving.
  cv::Mat mask(96, 128, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(0, 0, 64, 96)).setTo(255);
  WriteMask(scene / "motion_masks" / "0_00002.png", mask);

  const Workspace ws = ColmapWorkspace("learned_depth");
  DepthOptions o;
  o.dataset = scene;
  o.factor = 2;
  o.priors = scene;
  o.consistent_moving_depth = false;  // each frame's own alignment first
  const DepthSummary s = RunDepth(ws, o);
  EXPECT_EQ(s.frames.depth_source, kDepthFromPriors);
  EXPECT_EQ(s.with_learned_depth, 7);
  EXPECT_TRUE(s.alignment_failed.empty());
  const Json report = ReadJson(ws.depth() / "priors.json").at("frames");
  const bool report_has_pairs =
      ReadJson(ws.depth() / "priors.json").contains("moving_depth_pairs");
  const Dataset truth = LoadDataset(dir_->path() / "tiny", 2);
  for (const WorkspaceFrame& f : s.frames.train) {
    const Json* entry = nullptr;
    for (const Json& e : report)
      if (e.at("frame") == f.name) entry = &e;
    ASSERT_NE(entry, nullptr) << f.name;
    if (f.name == "0_00005") {
      EXPECT_EQ(entry->at("learned"), "no file");
      continue;
    }
    EXPECT_LT(entry->at("median_relative_error").get<double>(), 0.1) << *entry;
    if (f.name == "0_00002") {
      const cv::Mat m = ReadMask(f.dynamic_mask);
      EXPECT_EQ(cv::countNonZero(m(cv::Rect(0, 0, 32, 48))), 32 * 48);
      EXPECT_EQ(cv::countNonZero(m(cv::Rect(32, 0, 32, 48))), 0);
      continue;
    }
    // The moving pixels' depth against the truth.
    const cv::Mat depth = ReadDepthMap(f.depth);
    const cv::Mat moving = ReadMask(f.dynamic_mask);
    cv::Mat z;
    for (const DatasetFrame& t : truth.train)
      if (t.id == f.name) z = ReadDepth(t);
    std::vector<double> errors;
    int without = 0;
    for (int y = 0; y < z.rows; ++y)
      for (int x = 0; x < z.cols; ++x) {
        if (!moving.at<std::uint8_t>(y, x) || !(z.at<float>(y, x) > 0))
          continue;
        const float d = depth.at<float>(y, x);
        if (!(d > 0))
          ++without;
        else
          errors.push_back(std::abs(d - z.at<float>(y, x)) / z.at<float>(y, x));
      }
    if (errors.empty()) continue;
    EXPECT_EQ(without, 0) << f.name;
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2,
                     errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.1) << f.name;
  }

  // Made consistent along the flow: every frame with learned depth and a
  // neighbour gets its correction, and each neighbouring pair is compared.
  const Workspace ws2 = ColmapWorkspace("consistent_moving_depth");
  o.consistent_moving_depth = true;
  RunDepth(ws2, o);
  const Json consistent = ReadJson(ws2.depth() / "priors.json");
  int corrected = 0;
  for (const Json& e : consistent.at("frames")) {
    if (e.contains("moving_depth_log_scale")) {
      ++corrected;
      EXPECT_LT(std::abs(e.at("moving_depth_log_scale").get<double>()),
                kMaxMovingScaleCorrection + 1e-9);
    }
  }
  EXPECT_EQ(corrected, 8);
  EXPECT_EQ(consistent.at("moving_depth_pairs").size(), 7u);
  EXPECT_FALSE(report_has_pairs);
}

// The source of the Error `run` throws ("" when none).
template <typename Run>
std::string ErrorSource(Run run) {
  try {
    run();
  } catch (const Error& e) {
    return e.source();
  }
  return "";
}

// Bad dataset files are named by the depth stage, before any fit: a
// covisible mask of another size is an error; a depth map of 1e30 (a
// broken conversion) or NaN gives a warning and no depth.
TEST_F(DepthStageTest, BadDatasetFilesAreNamedBeforeTheFit) {
  const fs::path data = dir_->path() / "bad_files";
  fs::copy(dir_->path() / "tiny", data, fs::copy_options::recursive);
  const Workspace ws(dir_->path() / "bad_files_ws");
  DepthOptions o;
  o.dataset = data;
  const Dataset d = LoadDataset(data, 2);

  const fs::path mask = d.val[3].covisible;
  ASSERT_FALSE(mask.empty());
  const cv::Mat good_mask = ReadMask(mask);
  WriteMask(mask, cv::Mat(good_mask.rows / 2, good_mask.cols / 2, CV_8UC1,
                          cv::Scalar(255)));
  EXPECT_EQ(ErrorSource([&] { RunDepth(ws, o); }), mask.string());
  WriteMask(mask, good_mask);

  // 1e30 (a broken conversion) and NaN: no depth, said with the file.
  const fs::path depth = d.train[2].depth;
  const cv::Mat good_depth = ReadDepthMap(depth);
  for (const float bad : {1e30f, std::nanf("")}) {
    WriteDepthMap(depth, cv::Mat(good_depth.size(), CV_32F, cv::Scalar(bad)));
    std::ostringstream log;
    SetLogSink(&log);
    EXPECT_NO_THROW(RunDepth(ws, o));
    SetLogSink(nullptr);
    EXPECT_NE(log.str().find(depth.string() + ": no valid depth"),
              std::string::npos)
        << log.str();
    if (bad > 0) {
      EXPECT_NE(log.str().find(depth.string() + ": 3072 pixels beyond"),
                std::string::npos)
          << log.str();
    }
    EXPECT_EQ(cv::countNonZero(ReadDepthMap(ws.depth_map(d.train[2].id))), 0);
  }
}

// A COLMAP model whose cameras disagree with its images: stereo names the
// image instead of failing inside OpenCV.
TEST_F(DepthStageTest, AnImageOfAnotherSizeThanItsCameraIsNamed) {
  const Workspace ws = ColmapWorkspace("wrong_image_size");
  const fs::path image = ws.images() / "0_00001.png";
  const cv::Mat bgr = ReadImage(image).ToBgr8();
  cv::Mat half;
  cv::resize(bgr, half, cv::Size(bgr.cols / 2, bgr.rows / 2));
  WritePng8(image, half);
  DepthOptions o;
  EXPECT_EQ(ErrorSource([&] { RunDepth(ws, o); }), image.string());
}

// The stamp `run` reuses the stage by: written on completion, stale once
// an image of the COLMAP workspace (or the model) changes, as when
// `run --colmap` is given a workspace whose frames were replaced.
TEST_F(DepthStageTest, ItsStampNoticesAChangedImageOrModel) {
  const Workspace ws = ColmapWorkspace("stamped");
  DepthOptions o;
  const StageStamp stamp(ws, "depth");
  EXPECT_TRUE(stamp.StaleReason(DepthStageRecord(ws, o)).has_value());
  RunDepth(ws, o);
  EXPECT_EQ(stamp.StaleReason(DepthStageRecord(ws, o)), std::nullopt);
  const fs::path image = ws.images() / "0_00001.png";
  fs::last_write_time(image,
                      fs::last_write_time(image) + std::chrono::seconds(5));
  EXPECT_EQ(stamp.StaleReason(DepthStageRecord(ws, o)).value_or(""),
            "images/0_00001.png changed");
  RunDepth(ws, o);
  EXPECT_EQ(stamp.StaleReason(DepthStageRecord(ws, o)), std::nullopt);
  fs::remove(ws.sparse() / "0" / "points3D.bin");
  EXPECT_EQ(stamp.StaleReason(DepthStageRecord(ws, o)).value_or(""),
            "sparse/0/points3D.bin is gone");
  o.holdout = o.holdout + 1;
  EXPECT_NE(stamp.StaleReason(DepthStageRecord(ws, o))
                .value_or("")
                .find("option depth.holdout"),
            std::string::npos);
}

TEST_F(DepthStageTest, BadOptionsAreRefusedBeforeAnyWork) {
  DepthOptions o;
  o.holdout = 1;
  EXPECT_THROW(RunDepth(Workspace(dir_->path() / "bad"), o), Error);
  EXPECT_FALSE(fs::exists(dir_->path() / "bad"));
  o.holdout = 0;
  EXPECT_THROW(RunDepth(Workspace(dir_->path() / "bad"), o),
               Error);  // no sfm.json
}

}  // namespace
}  // namespace pano4d
