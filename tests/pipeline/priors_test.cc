// What the fit takes from a priors folder: flow and disparity on the
// training views, tracks over the times and as sparse flows, and the
// plan's lines.
#include "src/pipeline/priors.h"

#include <cmath>

#include <gtest/gtest.h>

#include "src/core/image.h"
#include "src/core/npy.h"
#include "src/core/npz.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

constexpr int kW = 16, kH = 12, kFrames = 4;

// Four frames of a dataset, 000.png ... at 16 x 12, time = index.
WorkspaceFrames Frames(const fs::path& dir) {
  WorkspaceFrames frames;
  frames.dataset = dir;
  frames.num_times = kFrames;
  for (int i = 0; i < kFrames; ++i) {
    WorkspaceFrame f;
    char name[16], image[16];
    std::snprintf(name, sizeof(name), "%05d", i);
    std::snprintf(image, sizeof(image), "%03d.png", i);
    f.name = name;
    f.time = i;
    f.rgb = dir / "images" / image;
    f.camera.camera = Camera{CameraModelId::kPinhole, kW, kH, {10, 10, 8, 6}};
    frames.train.push_back(f);
  }
  return frames;
}

std::vector<TrainingView> Views(const WorkspaceFrames& frames) {
  std::vector<TrainingView> views(frames.train.size());
  for (std::size_t i = 0; i < views.size(); ++i) {
    views[i].name = frames.train[i].name;
    views[i].time = frames.train[i].time;
    views[i].camera.width = kW;
    views[i].camera.height = kH;
  }
  return views;
}

NpyArray Constant(std::vector<std::int64_t> shape, float value) {
  std::int64_t n = 1;
  for (auto d : shape) n *= d;
  return NpyArray::FromFloats(shape, std::vector<float>(n, value));
}

TEST(AttachPriorsTest, FlowDisparityAndTracksReachTheViews) {
  const testing::TempDir dir;
  // Disparity at 2x for frames 0..2 (3 has none); flow 0 <-> 1 only.
  for (int i = 0; i < 3; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%03d.npy", i);
    WriteNpy(dir / "disp" / name, Constant({2 * kH, 2 * kW}, 1.0f + i));
  }
  WriteNpy(dir / "raft_exhaustive" / "000.png_001.png.npy",
           Constant({2 * kH, 2 * kW, 2}, 2.0f));
  WriteNpy(dir / "raft_exhaustive" / "001.png_000.png.npy",
           Constant({2 * kH, 2 * kW, 2}, -2.0f));
  // Two tracks over the 4 frames, at the disparity's 2x: the first seen
  // everywhere, the second hidden at frame 2.
  std::vector<float> xy, vis;
  for (int t = 0; t < kFrames; ++t)
    for (int k = 0; k < 2; ++k) {
      xy.push_back(4.0f + 2 * t);  // x at 2x: 2 + t at the frames' size
      xy.push_back(8.0f);
      vis.push_back(k == 1 && t == 2 ? 0.0f : 1.0f);
    }
  WriteNpz(dir / "cotracker_tap.npz",
           {{"tracks", NpyArray::FromFloats({kFrames, 2, 2}, xy)},
            {"visibility", NpyArray::FromFloats({kFrames, 2}, vis)}},
           true);

  const WorkspaceFrames frames = Frames(dir.path());
  std::vector<TrainingView> views = Views(frames);
  Tracks2D tracks;
  const nlohmann::json report =
      AttachPriors(ScanPriors(dir.path()), PriorVideoFrames({}, frames),
                   frames, &views, &tracks);
  EXPECT_EQ(report["disparity"]["frames_without"],
            nlohmann::json::array({"00003"}));
  ASSERT_EQ(views[2].disparity.size(), static_cast<std::size_t>(kW * kH));
  EXPECT_EQ(views[2].disparity[5], 3.0f);
  EXPECT_TRUE(views[3].disparity.empty());
  EXPECT_EQ(report["flow"]["pairs"], 2);
  EXPECT_EQ(report["flow"]["masks"]["forward-backward"], 2);

  // Tracks: over the times, at the frames' size.
  ASSERT_EQ(tracks.size(), 2u);
  EXPECT_EQ(tracks.pixel(0, 3).x(), 5.0f);
  EXPECT_FALSE(tracks.is_valid(1, 2));
  // Sparse flow where no dense flow is: 1 -> 2 (track 0 only, at its
  // pixel), 0 -> 2 (gap 2); the dense 0 -> 1 stays dense.
  const auto flow_to = [&](int a, int b) -> const TrainingView::Flow* {
    for (const TrainingView::Flow& f : views[a].flows)
      if (f.view == b) return &f;
    return nullptr;
  };
  ASSERT_NE(flow_to(0, 1), nullptr);
  EXPECT_EQ(flow_to(0, 1)->flow[0], 1.0f);  // dense, 2 px at 2x
  const TrainingView::Flow* sparse = flow_to(1, 2);
  ASSERT_NE(sparse, nullptr);
  const std::size_t p = 4 * kW + 3;  // track 0 at (3, 4) at time 1
  EXPECT_EQ(sparse->valid[p], kMaskOn);
  EXPECT_EQ(sparse->flow[2 * p], 1.0f);
  int valid = 0;
  for (std::uint8_t v : sparse->valid) valid += v != 0;
  EXPECT_EQ(valid, 1);
  ASSERT_NE(flow_to(0, 2), nullptr);
  EXPECT_EQ(flow_to(0, 3), nullptr);  // 3 apart: no pair
  EXPECT_EQ(report["tracks"]["tracks"], 2);
}

TEST(AttachPriorsTest, ThePlanSaysWhatEachLayoutIsFor) {
  const testing::TempDir dir;
  WriteNpy(dir / "disp" / "000.npy", Constant({kH, kW}, 1.0f));
  WriteNpy(dir / "unidepth_disp" / "000.npy", Constant({kH, kW}, 1.0f));
  WriteMask(dir / "motion_masks" / "000.png",
            cv::Mat(kH, kW, CV_8UC1, cv::Scalar(0)));
  const std::vector<std::string> lines = DescribePriorUse(ScanPriors(dir.path()));
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_NE(lines[0].find("unidepth_disp"), std::string::npos) << lines[0];
  EXPECT_NE(lines[0].find("aligned"), std::string::npos) << lines[0];
  EXPECT_NE(lines[1].find("not used: Shape of Motion unidepth_disp"),
            std::string::npos)
      << lines[1];
  EXPECT_NE(lines[2].find("dynamic masks"), std::string::npos) << lines[2];
  const std::vector<std::string> given =
      DescribePriorUse(ScanPriors(dir.path()), "the dataset's depth maps");
  EXPECT_NE(given[0].find("the dataset's depth maps"), std::string::npos)
      << given[0];
}

}  // namespace
}  // namespace pano4d
