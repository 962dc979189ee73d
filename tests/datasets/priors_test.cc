#include "src/datasets/priors.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/core/npy.h"
#include "src/core/npz.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

using testing::TempDir;

// The run's frames: 4 frames of 16 x 12 named as Nvidia's images
// (000.png ...), pano4d's names 00000 ...
constexpr int kW = 16, kH = 12, kFrames = 4;

std::vector<PriorFrame> Frames() {
  std::vector<PriorFrame> frames;
  for (int i = 0; i < kFrames; ++i) {
    char image[16], name[16];
    std::snprintf(image, sizeof(image), "%03d.png", i);
    std::snprintf(name, sizeof(name), "%05d", i);
    frames.push_back({name, std::filesystem::path("images") / image, kW, kH});
  }
  return frames;
}

// An (h, w) float32 array whose value at (y, x) is f(x, y).
template <typename F>
NpyArray Map(int w, int h, F f) {
  std::vector<float> v;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) v.push_back(static_cast<float>(f(x, y)));
  return NpyArray::FromFloats({h, w}, v);
}

// An (h, w, 2) flow of constant (u, v), float32 or float16.
NpyArray ConstantFlow(int w, int h, float u, float v, bool half = false) {
  std::vector<float> values;
  for (int i = 0; i < w * h; ++i) {
    values.push_back(u);
    values.push_back(v);
  }
  return half ? NpyArray::FromFloatsAsHalves({h, w, 2}, values)
              : NpyArray::FromFloats({h, w, 2}, values);
}

NpyArray BoolMask(int w, int h, bool value) {
  NpyArray a;
  a.kind = 'b';
  a.item_size = 1;
  a.shape = {h, w};
  a.data.assign(static_cast<std::size_t>(w) * h, value ? 1 : 0);
  return a;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(PriorsTest, DynamicNeRFDispAndFlowAtTwiceTheResolution) {
  const TempDir dir;
  // MiDaS disparity at 2x: the run's pixel (x, y) reads the file's (2x, 2y).
  for (int i = 0; i < kFrames; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%03d.npy", i);
    WriteNpy(dir / "disp" / name,
             Map(2 * kW, 2 * kH, [&](int x, int y) { return 1000 * i + x + 100 * y; }));
  }
  // flow/<i>_fwd.npz to i + 1 and _bwd.npz to i - 1, flow in 2x pixels.
  for (int i = 0; i < kFrames; ++i) {
    char name[32];
    if (i + 1 < kFrames) {
      std::snprintf(name, sizeof(name), "%03d_fwd.npz", i);
      WriteNpz(dir / "flow" / name,
               {{"flow", ConstantFlow(2 * kW, 2 * kH, 4, -2)},
                {"mask", BoolMask(2 * kW, 2 * kH, true)}});
    }
    if (i > 0) {
      std::snprintf(name, sizeof(name), "%03d_bwd.npz", i);
      WriteNpz(dir / "flow" / name,
               {{"flow", ConstantFlow(2 * kW, 2 * kH, -4, 2)},
                {"mask", BoolMask(2 * kW, 2 * kH, false)}});
    }
  }
  const PriorsFolder folder = ScanPriors(dir.path());
  ASSERT_EQ(folder.layouts.size(), 2u);
  const auto depth = ReadDepthPrior(folder, Frames());
  ASSERT_TRUE(depth);
  EXPECT_EQ(depth->layout->meaning, DepthMeaning::kDisparity);
  EXPECT_EQ(depth->source_width, 2 * kW);
  ASSERT_EQ(depth->maps[2].cols, kW);
  EXPECT_EQ(depth->maps[2].at<float>(3, 5), 2000 + 10 + 600);

  const auto flow = ReadFlowPrior(folder, Frames());
  ASSERT_TRUE(flow);
  ASSERT_EQ(flow->fields.size(), 6u);  // 3 forward, 3 backward
  for (const FlowField& f : flow->fields) {
    EXPECT_EQ(std::abs(f.to - f.from), 1);
    EXPECT_EQ(f.mask_source, "file");
    const cv::Vec2f v = f.flow.at<cv::Vec2f>(4, 4);
    // Scaled with the image: 4 px at 2x is 2 px here.
    EXPECT_EQ(v[0], f.to > f.from ? 2.0f : -2.0f);
    EXPECT_EQ(v[1], f.to > f.from ? -1.0f : 1.0f);
    EXPECT_EQ(cv::countNonZero(f.valid), f.to > f.from ? kW * kH : 0);
  }
}

TEST(PriorsTest, OmniMotionFlowGetsAForwardBackwardMask) {
  const TempDir dir;
  // 000.png -> 001.png and back, consistent except in the left half of
  // the way back.
  WriteNpy(dir / "raft_exhaustive" / "000.png_001.png.npy",
           ConstantFlow(kW, kH, 1, 0));
  std::vector<float> back;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      back.push_back(x < kW / 2 ? 5.0f : -1.0f);
      back.push_back(0.0f);
    }
  WriteNpy(dir / "raft_exhaustive" / "001.png_000.png.npy",
           NpyArray::FromFloats({kH, kW, 2}, back));
  // A pair further apart than the neighbours: not read by default.
  WriteNpy(dir / "raft_exhaustive" / "000.png_003.png.npy",
           ConstantFlow(kW, kH, 3, 0));
  const auto flow = ReadFlowPrior(ScanPriors(dir.path()), Frames());
  ASSERT_TRUE(flow);
  ASSERT_EQ(flow->fields.size(), 2u);
  const FlowField& fwd = flow->fields[0];
  EXPECT_EQ(fwd.from, 0);
  EXPECT_EQ(fwd.to, 1);
  EXPECT_EQ(fwd.mask_source, "forward-backward");
  // x + 1 lands in the consistent half from x = kW / 2 - 1 on.
  EXPECT_EQ(fwd.valid.at<std::uint8_t>(5, 2), 0);
  EXPECT_EQ(fwd.valid.at<std::uint8_t>(5, 10), kMaskOn);
  const auto far = ReadFlowPrior(ScanPriors(dir.path()), Frames(), 3);
  EXPECT_EQ(far->fields.size(), 3u);

  // filter_raft.py's raft_masks/: red where cycle-consistent, preferred to
  // the forward-backward check.
  cv::Mat mask(kH, kW, CV_8UC3, cv::Scalar(0, 0, 0));
  mask(cv::Rect(0, 0, 3, kH)).setTo(cv::Scalar(0, 0, 255));  // BGR red
  std::filesystem::create_directories(dir / "raft_masks");
  cv::imwrite((dir / "raft_masks" / "000.png_001.png.png").string(), mask);
  const auto masked = ReadFlowPrior(ScanPriors(dir.path()), Frames());
  EXPECT_EQ(masked->fields[0].mask_source, "file");
  EXPECT_EQ(cv::countNonZero(masked->fields[0].valid), 3 * kH);
}

TEST(PriorsTest, MoScaFloat16FlowMetricDepthTracksAndMasks) {
  const TempDir dir;
  // raft_wrapper.py names pairs by the images it read (00000.jpg); the
  // run's frames are 000.png / 00000: the stem names the frame.
  WriteNpz(dir / "flow_raft" / "00000.jpg_to_00001.jpg.npz",
           {{"flow", ConstantFlow(kW, kH, 0.5f, 0.25f, true)},
            {"mask", BoolMask(kW, kH, true)}},
           true);
  for (int i = 0; i < kFrames; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%05d.npz", i);
    WriteNpz(dir / "metric3d_depth" / name,
             {{"dep", Map(kW, kH, [](int x, int) { return x == 0 ? 0 : 2.5; })}},
             true);
  }
  // Tracks: (T, N, 2) and (T, N), N = 3, in pixels of the frames.
  std::vector<float> xy;
  std::vector<float> vis;
  for (int t = 0; t < kFrames; ++t)
    for (int k = 0; k < 3; ++k) {
      xy.push_back(1.0f + k + t);
      xy.push_back(2.0f);
      vis.push_back(t == 1 && k == 2 ? 0.0f : 1.0f);
    }
  NpyArray visibility = NpyArray::FromFloats({kFrames, 3}, vis);
  WriteNpz(dir / "bootstapir_tap.npz",
           {{"tracks", NpyArray::FromFloats({kFrames, 3, 2}, xy)},
            {"visibility", visibility}});
  // DEVA's instance colours: any non-black pixel is the object.
  cv::Mat annotation(kH, kW, CV_8UC3, cv::Scalar(0, 0, 0));
  annotation(cv::Rect(0, 0, 4, 4)).setTo(cv::Scalar(0, 128, 0));
  std::filesystem::create_directories(dir / "vos_deva" / "Annotations");
  cv::imwrite((dir / "vos_deva" / "Annotations" / "00001.png").string(),
              annotation);

  const PriorsFolder folder = ScanPriors(dir.path());
  const auto depth = ReadDepthPrior(folder, Frames());
  ASSERT_TRUE(depth);
  EXPECT_EQ(depth->layout->meaning, DepthMeaning::kMetricDepth);
  EXPECT_EQ(depth->maps[1].at<float>(2, 0), 0.0f);
  EXPECT_EQ(depth->maps[1].at<float>(2, 3), 2.5f);

  const auto flow = ReadFlowPrior(folder, Frames());
  ASSERT_EQ(flow->fields.size(), 1u);
  EXPECT_EQ(flow->fields[0].flow.at<cv::Vec2f>(1, 1)[0], 0.5f);

  const auto tracks = ReadTrackPrior(folder, Frames());
  ASSERT_TRUE(tracks);
  ASSERT_EQ(tracks->size(), 3u);
  EXPECT_EQ(tracks->pixels[2 * kFrames + 3].x(), 6.0f);  // k 2 at t 3
  EXPECT_EQ(tracks->visible[2 * kFrames + 1], 0);
  EXPECT_EQ(tracks->visible[2 * kFrames + 2], 1);

  const auto masks = ReadMaskPrior(folder, Frames());
  ASSERT_TRUE(masks);
  EXPECT_TRUE(masks->masks[0].empty());
  EXPECT_EQ(cv::countNonZero(masks->masks[1]), 16);
  EXPECT_EQ(FramesWithout(masks->masks, Frames()).size(), 3u);
}

TEST(PriorsTest, ShapeOfMotionLayouts) {
  const TempDir dir;
  // aligned_depth_anything/ (disparity), depth_anything/ (uint16 PNG):
  // the aligned one is preferred.
  WriteNpy(dir / "aligned_depth_anything" / "00000.npy",
           Map(kW, kH, [](int, int) { return 0.5; }));
  std::filesystem::create_directories(dir / "depth_anything");
  cv::imwrite((dir / "depth_anything" / "00000.png").string(),
              cv::Mat(kH, kW, CV_16UC1, cv::Scalar(40000)));
  // bootstapir/<q>_<t>.npy: query frame 0's 2 points at frames 0 and 1.
  for (int t = 0; t < 2; ++t) {
    const std::vector<float> rows = {
        3.0f + t, 4.0f, -10.0f, -10.0f,  // seen
        5.0f, 6.0f, 10.0f, -10.0f};      // occluded
    char name[32];
    std::snprintf(name, sizeof(name), "00000_%05d.npy", t);
    WriteNpy(dir / "bootstapir" / name, NpyArray::FromFloats({2, 4}, rows));
  }
  std::filesystem::create_directories(dir / "masks");
  cv::Mat mask(kH, kW, CV_8UC1, cv::Scalar(0));
  mask(cv::Rect(2, 2, 3, 3)).setTo(1);  // foreground > 0
  cv::imwrite((dir / "masks" / "00002.png").string(), mask);

  const PriorsFolder folder = ScanPriors(dir.path());
  EXPECT_EQ(folder.Of(PriorKind::kDepth).size(), 2u);
  const auto depth = ReadDepthPrior(folder, Frames());
  EXPECT_EQ(depth->maps[0].at<float>(0, 0), 0.5f);
  const auto tracks = ReadTrackPrior(folder, Frames());
  ASSERT_EQ(tracks->size(), 2u);
  EXPECT_EQ(tracks->pixels[1].x(), 4.0f);
  EXPECT_EQ(tracks->visible[0], 1);
  EXPECT_EQ(tracks->visible[kFrames], 0);  // point 2 occluded
  EXPECT_EQ(tracks->visible[2], 0);         // no file for frame 2
  const auto masks = ReadMaskPrior(folder, Frames());
  EXPECT_EQ(cv::countNonZero(masks->masks[2]), 9);
}

TEST(PriorsTest, DepthAnythingPngAndCoTrackerArrays) {
  const TempDir dir;
  std::filesystem::create_directories(dir / "depth_anything");
  cv::imwrite((dir / "depth_anything" / "001.png").string(),
              cv::Mat(kH, kW, CV_16UC1, cv::Scalar(40000)));
  // CoTracker's (1, T, N, 2) and (1, T, N), saved by the user.
  std::vector<float> xy(kFrames * 2 * 2, 1.0f);
  WriteNpz(dir / "cotracker.npz",
           {{"pred_tracks", NpyArray::FromFloats({1, kFrames, 2, 2}, xy)},
            {"pred_visibility",
             NpyArray::FromFloats({1, kFrames, 2},
                                  std::vector<float>(kFrames * 2, 1.0f))}});
  const PriorsFolder folder = ScanPriors(dir.path());
  const auto depth = ReadDepthPrior(folder, Frames());
  EXPECT_EQ(depth->maps[1].at<float>(0, 0), 40000.0f);
  EXPECT_EQ(FramesWithout(depth->maps, Frames()).size(), 3u);
  // Tracks at another resolution than the frames: scaled.
  const auto tracks = ReadTrackPrior(folder, Frames(), 2 * kW, 2 * kH);
  ASSERT_EQ(tracks->size(), 2u);
  EXPECT_EQ(tracks->pixels[0].x(), 0.5f);
}

TEST(PriorsTest, BadInputNamesTheFileAndTheProblem) {
  {
    const TempDir dir;
    WriteNpy(dir / "disp" / "000.npy",
             Map(kW, kH, [](int x, int) { return x == 3 ? NAN : 1.0; }));
    const std::string e = ErrorOf(
        [&] { ReadDepthPrior(ScanPriors(dir.path()), Frames()); });
    EXPECT_NE(e.find("000.npy"), std::string::npos) << e;
    EXPECT_NE(e.find("NaN or Inf"), std::string::npos) << e;
  }
  {
    const TempDir dir;  // another aspect ratio
    WriteNpy(dir / "disp" / "000.npy", Map(kW, kW, [](int, int) { return 1; }));
    const std::string e = ErrorOf(
        [&] { ReadDepthPrior(ScanPriors(dir.path()), Frames()); });
    EXPECT_NE(e.find("aspect ratio"), std::string::npos) << e;
  }
  {
    const TempDir dir;  // a frame the video does not have
    WriteNpy(dir / "raft_exhaustive" / "000.png_017.png.npy",
             ConstantFlow(kW, kH, 1, 0));
    const std::string e = ErrorOf(
        [&] { ReadFlowPrior(ScanPriors(dir.path()), Frames()); });
    EXPECT_NE(e.find("000.png_017.png.npy"), std::string::npos) << e;
    EXPECT_NE(e.find("000, 001, 002"), std::string::npos) << e;
  }
  {
    const TempDir dir;  // tracks over another number of frames
    WriteNpz(dir / "x_tap.npz",
             {{"tracks", NpyArray::FromFloats({2, 1, 2}, {1, 1, 1, 1})},
              {"visibility", NpyArray::FromFloats({2, 1}, {1, 1})}});
    const std::string e = ErrorOf(
        [&] { ReadTrackPrior(ScanPriors(dir.path()), Frames()); });
    EXPECT_NE(e.find("x_tap.npz"), std::string::npos) << e;
    EXPECT_NE(e.find("number of frames"), std::string::npos) << e;
  }
  {
    const TempDir dir;  // nothing pano4d reads
    std::filesystem::create_directories(dir / "depth_pro");
    testing::WriteText(dir / "notes.txt", "x");
    const std::string e = ErrorOf([&] { ScanPriors(dir.path()); });
    EXPECT_NE(e.find("depth_pro/"), std::string::npos) << e;
    EXPECT_NE(e.find("DynamicNeRF disp/"), std::string::npos) << e;
  }
  EXPECT_NE(ErrorOf([] { ScanPriors("/no/such/folder"); }).find("/no/such"),
            std::string::npos);
}

TEST(PriorsTest, UnusedFramesAreKnownButNotRead) {
  const TempDir dir;
  WriteNpy(dir / "disp" / "000.npy", Map(kW, kH, [](int, int) { return 1; }));
  WriteNpy(dir / "disp" / "001.npy", Map(kW, kH, [](int, int) { return 1; }));
  std::vector<PriorFrame> frames = Frames();
  frames[1].used = false;  // held out
  const auto depth = ReadDepthPrior(ScanPriors(dir.path()), frames);
  EXPECT_FALSE(depth->maps[0].empty());
  EXPECT_TRUE(depth->maps[1].empty());
  EXPECT_EQ(FramesWithout(depth->maps, frames),
            (std::vector<std::string>{"00002", "00003"}));
}

}  // namespace
}  // namespace pano4d
