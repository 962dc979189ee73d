#include "src/geometry/motion_segmentation.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "src/core/error.h"
#include "src/core/image.h"
#include "src/datasets/synth_generate.h"
#include "src/datasets/synth_render.h"
#include "tests/support/synth_video.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

// A video with its ground truth (255 = on a moving object).
struct Video {
  std::vector<cv::Mat> frames;  // as ComputeDynamicMasks takes them
  std::vector<cv::Mat> truth;
};

// The training video of a GenerateSynthScene folder at "1x" or "2x", read as
// pano4d reads images (float RGB), so that path is covered too.
Video ReadSynthVideo(const fs::path& root, const std::string& resolution,
                     int frames) {
  Video video;
  for (int t = 0; t < frames; ++t) {
    char name[32];
    std::snprintf(name, sizeof(name), "0_%05d.png", t);
    video.frames.push_back(ReadImage(root / "rgb" / resolution / name).mat());
    video.truth.push_back(ReadMask(root / "dynamic" / resolution / name));
  }
  return video;
}

// The dense synthetic video (tests/support/synth_video.h).
Video RenderDenseVideo(bool is_static) {
  const testing::DenseSynthVideo dense =
      testing::FilmDenseSynthVideo(is_static);
  Video video;
  for (const synth::RenderedFrame& frame : dense.frames) {
    video.frames.push_back(frame.rgb.ToBgr8());
    video.truth.push_back(frame.dynamic);
  }
  return video;
}

struct Scores {
  double recall = 0.0;               // of the true dynamic pixels
  double false_positive_rate = 0.0;  // of the true static pixels
  // Of the static pixels farther than 3% of the diagonal from any dynamic
  // one: the masks are dilated on purpose, this is what is left.
  double far_false_positive_rate = 0.0;
  double dynamic_fraction = 0.0;
};

Scores Score(const std::vector<cv::Mat>& masks,
             const std::vector<cv::Mat>& truth) {
  double tp = 0, fn = 0, fp = 0, tn = 0, far_fp = 0, far = 0, all = 0;
  for (std::size_t i = 0; i < masks.size(); ++i) {
    const cv::Mat m = masks[i] != 0, t = truth[i] != 0;
    const int r =
        static_cast<int>(std::lround(0.03 * std::hypot(t.cols, t.rows)));
    cv::Mat near;
    cv::dilate(t, near,
               cv::getStructuringElement(cv::MORPH_ELLIPSE,
                                         cv::Size(2 * r + 1, 2 * r + 1)));
    tp += cv::countNonZero(m & t);
    fn += cv::countNonZero(~m & t);
    fp += cv::countNonZero(m & ~t);
    tn += cv::countNonZero(~m & ~t);
    far_fp += cv::countNonZero(m & ~near);
    far += cv::countNonZero(~near);
    all += m.total();
  }
  Scores s;
  s.recall = tp + fn > 0 ? tp / (tp + fn) : 1.0;
  s.false_positive_rate = fp + tn > 0 ? fp / (fp + tn) : 0.0;
  s.far_false_positive_rate = far > 0 ? far_fp / far : 0.0;
  s.dynamic_fraction = (tp + fp) / all;
  return s;
}

void Print(const std::string& what, const Scores& s,
           const DynamicMaskStats& stats) {
  std::printf(
      "[ scores   ] %s: recall %.3f, false positives %.4f (%.4f away from "
      "objects), dynamic %.3f\n[ stats    ] %s\n",
      what.c_str(), s.recall, s.false_positive_rate, s.far_false_positive_rate,
      s.dynamic_fraction, stats.BriefReport().c_str());
}

// ctest runs every test case in its own process, so each scene is made on
// first use only, and shared by the cases of one gtest run.
class DynamicMasksTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() {
    dense_.reset();
    scenes_.reset();
  }
  // The tiny preset, seed 1: "dynamic" or "static".
  static fs::path Scene(const std::string& name) {
    if (!scenes_) scenes_ = std::make_unique<testing::TempDir>();
    const fs::path root = scenes_->path() / name;
    if (!fs::exists(root / "synth.json")) {
      synth::GenerateSynthScene(
          {.preset = "tiny", .seed = 1, .is_static = name == "static"}, root);
    }
    return root;
  }
  static const Video& DenseDynamic() {
    if (!dense_) {
      dense_ = std::make_unique<Video>(RenderDenseVideo(/*is_static=*/false));
    }
    return *dense_;
  }
  static constexpr int kTinyFrames = 8;

 private:
  static std::unique_ptr<testing::TempDir> scenes_;
  static std::unique_ptr<Video> dense_;
};
std::unique_ptr<testing::TempDir> DynamicMasksTest::scenes_;
std::unique_ptr<Video> DynamicMasksTest::dense_;

TEST(DynamicMaskOptionsTest, CheckNamesTheWrongField) {
  EXPECT_NO_THROW(DynamicMaskOptions{}.Check());
  const auto field_of = [](DynamicMaskOptions o) {
    try {
      o.Check();
    } catch (const Error& e) {
      return e.field();
    }
    return std::string("(none)");
  };
  DynamicMaskOptions o;
  o.frame_gaps = {1, 1};
  EXPECT_EQ(field_of(o), "frame_gaps");
  o = {};
  o.frame_gaps = {0};
  EXPECT_EQ(field_of(o), "frame_gaps");
  o = {};
  o.residual_threshold = 0.0;
  EXPECT_EQ(field_of(o), "residual_threshold");
  o = {};
  o.dilation_radius = 1.5;
  EXPECT_EQ(field_of(o), "dilation_radius");
  o = {};
  o.agreement = 0.0;
  EXPECT_EQ(field_of(o), "agreement");
  o = {};
  o.working_long_side = 8;
  EXPECT_EQ(field_of(o), "working_long_side");
  o = {};
  o.min_correspondences = 3;
  EXPECT_EQ(field_of(o), "min_correspondences");
}

TEST_F(DynamicMasksTest, DynamicSceneIsFoundWithFewFalsePositives) {
  const Video video = ReadSynthVideo(Scene("dynamic"), "1x", kTinyFrames);
  DynamicMaskStats stats;
  const std::vector<cv::Mat> masks =
      ComputeDynamicMasks(video.frames, {}, &stats);
  ASSERT_EQ(masks.size(), video.frames.size());
  for (std::size_t i = 0; i < masks.size(); ++i) {
    EXPECT_EQ(masks[i].type(), CV_8UC1);
    EXPECT_EQ(masks[i].size(), video.frames[i].size());
    EXPECT_EQ(cv::countNonZero((masks[i] != 0) & (masks[i] != 255)), 0);
    EXPECT_GT(stats.frames[i].neighbours_used, 0) << "frame " << i;
    EXPECT_GT(stats.frames[i].inlier_ratio, 0.7) << "frame " << i;
    EXPECT_FALSE(stats.frames[i].static_camera);
  }
  const Scores s = Score(masks, video.truth);
  Print("tiny synthetic scene, 8 frames 128x96", s, stats);
  // Ground truth marks whole moving objects, also where they are about to
  // start or end their motion, so recall cannot reach 1. Masks all 0 fail
  // the first line, masks all 255 the second.
  EXPECT_GT(s.recall, 0.45);
  EXPECT_LT(s.false_positive_rate, 0.15);
  EXPECT_LT(s.far_false_positive_rate, 0.1);
}

TEST_F(DynamicMasksTest, DenseVideoIsFoundWithFewFalsePositives) {
  const Video& video = DenseDynamic();
  DynamicMaskStats stats;
  const Scores s =
      Score(ComputeDynamicMasks(video.frames, {}, &stats), video.truth);
  Print("synthetic scene, 24 frames 256x192", s, stats);
  EXPECT_GT(s.recall, 0.55);
  EXPECT_LT(s.false_positive_rate, 0.06);
  EXPECT_LT(s.far_false_positive_rate, 0.015);
}

TEST_F(DynamicMasksTest, StaticSceneIsAlmostAllStatic) {
  DynamicMaskStats stats;
  const Video dense = RenderDenseVideo(/*is_static=*/true);
  const Scores s_dense =
      Score(ComputeDynamicMasks(dense.frames, {}, &stats), dense.truth);
  Print("static synthetic scene, 24 frames 256x192", s_dense, stats);
  EXPECT_LT(s_dense.dynamic_fraction, 0.03);

  // The tiny preset's wide baseline leaves flow errors that look like
  // motion in a few places (thin repeated rings, a striped floor).
  const Video tiny = ReadSynthVideo(Scene("static"), "1x", kTinyFrames);
  const Scores s_tiny =
      Score(ComputeDynamicMasks(tiny.frames, {}, &stats), tiny.truth);
  Print("static tiny synthetic scene, 8 frames 128x96", s_tiny, stats);
  EXPECT_LT(s_tiny.dynamic_fraction, 0.12);
}

TEST_F(DynamicMasksTest, SameFramesAtTwoSizesGiveTheSameMasks) {
  // The middle 12 frames of the dense video (its objects all move there),
  // at 256x192 and halved.
  const Video& video = DenseDynamic();
  const std::vector<cv::Mat> full(video.frames.begin() + 6,
                                  video.frames.begin() + 18);
  std::vector<cv::Mat> half(full.size());
  for (std::size_t i = 0; i < half.size(); ++i) {
    cv::resize(full[i], half[i], cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  }
  DynamicMaskStats full_stats, half_stats;
  const std::vector<cv::Mat> full_masks =
      ComputeDynamicMasks(full, {}, &full_stats);
  const std::vector<cv::Mat> half_masks =
      ComputeDynamicMasks(half, {}, &half_stats);
  double overlap = 0, either = 0;
  for (std::size_t i = 0; i < half.size(); ++i) {
    ASSERT_EQ(half_masks[i].size(), half[i].size());
    cv::Mat up;
    cv::resize(half_masks[i], up, full_masks[i].size(), 0, 0,
               cv::INTER_NEAREST);
    overlap += cv::countNonZero(up & full_masks[i]);
    either += cv::countNonZero(up | full_masks[i]);
  }
  const double f1 = full_stats.MeanDynamicFraction();
  const double f2 = half_stats.MeanDynamicFraction();
  std::printf("[ scores   ] 256x192: dynamic %.4f; 128x96: %.4f; IoU %.3f\n",
              f1, f2, overlap / either);
  // The halved frames, resampled up to the working size, carry less detail:
  // their flow blurs more across object borders.
  EXPECT_NEAR(f2, f1, 0.3 * f1);
  EXPECT_GT(overlap / either, 0.6);

  // The DyCheck layout's own 1x and 2x frames (128x96 and 64x48).
  DynamicMaskStats stats_1x, stats_2x;
  ComputeDynamicMasks(
      ReadSynthVideo(Scene("dynamic"), "1x", kTinyFrames).frames, {},
      &stats_1x);
  ComputeDynamicMasks(
      ReadSynthVideo(Scene("dynamic"), "2x", kTinyFrames).frames, {},
      &stats_2x);
  const double t1 = stats_1x.MeanDynamicFraction();
  const double t2 = stats_2x.MeanDynamicFraction();
  std::printf("[ scores   ] tiny 1x: dynamic %.4f; 2x: %.4f\n", t1, t2);
  EXPECT_NEAR(t2, t1, 0.3 * t1);
}

// A textured square pasted into copies of one frame, moving by `step` per
// frame; `warp` moves the background (the camera) for frame t.
Video PastedObjectVideo(
    const cv::Mat& background, int frames, cv::Point step,
    const std::function<cv::Mat(const cv::Mat&, int)>& warp) {
  constexpr int kSide = 24;
  cv::Mat square(kSide, kSide, CV_8UC3);
  cv::RNG rng(7);
  for (int y = 0; y < kSide; ++y) {
    for (int x = 0; x < kSide; ++x) {
      const int c = ((x / 6 + y / 6) % 2) ? 230 : 30;
      square.at<cv::Vec3b>(y, x) =
          cv::Vec3b(c, 255 - c, c / 2 + rng.uniform(0, 40));
    }
  }
  Video video;
  for (int t = 0; t < frames; ++t) {
    cv::Mat frame = warp(background, t);
    cv::Mat truth = cv::Mat::zeros(frame.size(), CV_8U);
    const cv::Rect where(cv::Point(16, 16) + t * step, cv::Size(kSide, kSide));
    square.copyTo(frame(where));
    truth(where).setTo(255);
    video.frames.push_back(frame);
    video.truth.push_back(truth);
  }
  return video;
}

TEST_F(DynamicMasksTest, StaticCameraMarksTheMovingObjectByItsFlow) {
  const cv::Mat background =
      ReadImage(Scene("static") / "rgb" / "1x" / "0_00000.png").ToBgr8();
  const Video video = PastedObjectVideo(
      background, 8, {9, 5}, [](const cv::Mat& b, int) { return b.clone(); });
  DynamicMaskStats stats;
  const Scores s =
      Score(ComputeDynamicMasks(video.frames, {}, &stats), video.truth);
  Print("static camera, pasted square", s, stats);
  for (const DynamicMaskFrameStats& f : stats.frames) {
    EXPECT_TRUE(f.static_camera);
  }
  EXPECT_GT(s.recall, 0.9);
  EXPECT_LT(s.far_false_positive_rate, 0.01);
}

// The masks of the synthetic small scene (seed 0) filmed with `motion`,
// its 48 training frames at 2x, scored against the ground truth.
Scores ScoreSmallSceneFilmed(synth::TrainingMotion motion,
                             const std::string& what, DynamicMaskStats* stats) {
  testing::TempDir dir;
  synth::GenerateSynthScene(
      {.preset = "small", .seed = 0, .trajectory = motion}, dir / "scene");
  const Video video = ReadSynthVideo(dir / "scene", "2x", 48);
  const Scores s =
      Score(ComputeDynamicMasks(video.frames, {}, stats), video.truth);
  Print(what + ", synthetic small scene", s, *stats);
  return s;
}

int FramesJudgedByAHomography(const DynamicMaskStats& stats) {
  int n = 0;
  for (const DynamicMaskFrameStats& f : stats.frames) n += f.homography ? 1 : 0;
  return n;
}

// The synthetic scene filmed by a camera that stands still (synth
// --trajectory static-camera): its moving objects must be found by their
// flow. Issue 36 asks 80% of the objects' pixels at 5% false positives.
// The video is judged held still (longer gaps, a narrower margin); the far
// false positives stay at the 1% of the other tests.
TEST(DynamicMasksStaticCameraTest, SlowObjectsBeforeAStillCameraAreFound) {
  DynamicMaskStats stats;
  const Scores s = ScoreSmallSceneFilmed(synth::TrainingMotion::kStatic,
                                         "static camera", &stats);
  EXPECT_TRUE(stats.held_still);
  for (const DynamicMaskFrameStats& f : stats.frames)
    EXPECT_TRUE(f.static_camera);
  EXPECT_GE(s.recall, 0.8);
  EXPECT_LE(s.false_positive_rate, 0.05);
  EXPECT_LE(s.far_false_positive_rate, 0.01);
}

// The same scene filmed by a camera held still by hand (synth --trajectory
// handheld-still): its drift and tremor move the frame by about a pixel,
// below the static threshold. Judged by the flow magnitude, that motion
// widened the noise threshold until the slow objects faded from the masks
// (the nearly still clip; recall 0.68 here); a homography explains
// it instead, and the video is judged held still.
TEST(DynamicMasksStaticCameraTest, ACameraHeldStillByHandStillFindsTheObjects) {
  DynamicMaskStats stats;
  const Scores s = ScoreSmallSceneFilmed(synth::TrainingMotion::kHandheldStill,
                                         "camera held still by hand", &stats);
  EXPECT_TRUE(stats.held_still);
  EXPECT_GE(FramesJudgedByAHomography(stats), 24);
  EXPECT_GE(s.recall, 0.75);
  EXPECT_LE(s.false_positive_rate, 0.05);
  EXPECT_LE(s.far_false_positive_rate, 0.01);
}

TEST_F(DynamicMasksTest, PanningCameraIsJudgedByAHomography) {
  const cv::Mat background =
      ReadImage(Scene("static") / "rgb" / "1x" / "0_00000.png").ToBgr8();
  // Pan and roll: every frame is a homography of the first, so there is no
  // parallax to define a fundamental matrix.
  const auto pan = [](const cv::Mat& b, int t) {
    cv::Mat m = cv::getRotationMatrix2D(
        cv::Point2f(b.cols / 2.0f, b.rows / 2.0f), 0.6 * t, 1.0 + 0.01 * t);
    m.at<double>(0, 2) += 2.0 * t;
    cv::Mat out;
    cv::warpAffine(b, out, m, b.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    return out;
  };
  const Video video = PastedObjectVideo(background, 8, {2, 6}, pan);
  DynamicMaskStats stats;
  const Scores s =
      Score(ComputeDynamicMasks(video.frames, {}, &stats), video.truth);
  Print("panning camera, pasted square", s, stats);
  EXPECT_FALSE(stats.held_still);
  EXPECT_GE(FramesJudgedByAHomography(stats), 6);
  EXPECT_GT(s.recall, 0.9);
  EXPECT_LT(s.far_false_positive_rate, 0.01);
}

TEST_F(DynamicMasksTest, EveryInputTypeGivesTheSameMasks) {
  const Video video = ReadSynthVideo(Scene("dynamic"), "1x", 4);
  std::vector<cv::Mat> bgr8, bgra8, grey8, bgr16;
  for (const cv::Mat& rgb : video.frames) {
    cv::Mat bgr, m;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    bgr.convertTo(m, CV_8UC3, 255.0);
    bgr8.push_back(m);
    cv::cvtColor(m, bgra8.emplace_back(), cv::COLOR_BGR2BGRA);
    cv::cvtColor(m, grey8.emplace_back(), cv::COLOR_BGR2GRAY);
    m.convertTo(bgr16.emplace_back(), CV_16UC3, 257.0);
  }
  const std::vector<cv::Mat> expected = ComputeDynamicMasks(bgr8);
  for (const auto* input : {&bgra8, &grey8, &bgr16}) {
    const std::vector<cv::Mat> masks = ComputeDynamicMasks(*input);
    for (std::size_t i = 0; i < masks.size(); ++i) {
      EXPECT_EQ(cv::countNonZero(masks[i] != expected[i]), 0)
          << "frame " << i << " of type " << (*input)[i].type();
    }
  }
}

TEST(DynamicMasksInputTest, NoFramesGiveNoMasks) {
  DynamicMaskStats stats;
  stats.frames.resize(3);
  EXPECT_TRUE(ComputeDynamicMasks({}, {}, &stats).empty());
  EXPECT_TRUE(stats.frames.empty());
}

TEST(DynamicMasksInputTest, OneFrameIsAllStatic) {
  DynamicMaskStats stats;
  const std::vector<cv::Mat> masks = ComputeDynamicMasks(
      {cv::Mat(48, 64, CV_8UC3, cv::Scalar(10, 200, 30))}, {}, &stats);
  ASSERT_EQ(masks.size(), 1u);
  EXPECT_EQ(masks[0].size(), cv::Size(64, 48));
  EXPECT_EQ(cv::countNonZero(masks[0]), 0);
  ASSERT_EQ(stats.frames.size(), 1u);
  EXPECT_EQ(stats.frames[0].neighbours, 0);
  EXPECT_EQ(stats.frames[0].neighbours_used, 0);
}

TEST(DynamicMasksInputTest, BlankFramesHaveNoUsableNeighbour) {
  // Nothing to track: too few consistent correspondences, nothing marked.
  const std::vector<cv::Mat> frames(3,
                                    cv::Mat(48, 64, CV_8UC1, cv::Scalar(90)));
  DynamicMaskStats stats;
  const std::vector<cv::Mat> masks = ComputeDynamicMasks(frames, {}, &stats);
  for (const cv::Mat& m : masks) EXPECT_EQ(cv::countNonZero(m), 0);
  for (const DynamicMaskFrameStats& f : stats.frames) {
    EXPECT_LE(f.neighbours_used, f.neighbours);
  }
}

TEST(DynamicMasksInputTest, ErrorsNameTheFrame) {
  const cv::Mat a(48, 64, CV_8UC3, cv::Scalar::all(0));
  const cv::Mat b(24, 32, CV_8UC3, cv::Scalar::all(0));
  try {
    ComputeDynamicMasks({a, a, b});
    FAIL() << "frames of different sizes were accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "frame 2");
    EXPECT_EQ(e.field(), "size");
    EXPECT_NE(std::string(e.what()).find("32x24"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("64x48"), std::string::npos);
  }
  try {
    ComputeDynamicMasks({a, cv::Mat()});
    FAIL() << "an empty frame was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "frame 1");
  }
  try {
    ComputeDynamicMasks({cv::Mat(48, 64, CV_8SC1, cv::Scalar(0))});
    FAIL() << "a signed 8-bit frame was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.source(), "frame 0");
    EXPECT_EQ(e.field(), "type");
  }
}

}  // namespace
}  // namespace pano4d
