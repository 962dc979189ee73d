#include "src/pano/prior.h"

#include "src/pano/warp.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>

#include <opencv2/imgproc.hpp>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "src/core/json.h"
#include "src/core/log.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 32, kHeight = 24;
constexpr float kFocal = 30, kPlaneZ = 2;

// A camera looking down +z from (centre_x, 0, 0): on the plane z = 2 one
// unit of centre_x is fx / z = 15 pixels of image shift.
RasterCamera PlaneCamera(float centre_x) {
  RasterCamera c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = c.fy = kFocal;
  c.cx = kWidth / 2.0f;
  c.cy = kHeight / 2.0f;
  c.translation = Eigen::Vector3f(-centre_x, 0, 0);
  return c;
}

// The plane's world point under pixel (x, y) of a PlaneCamera.
cv::Point2d WorldPoint(float centre_x, int x, int y) {
  return {centre_x + (x + 0.5 - kWidth / 2.0) / kFocal * kPlaneZ,
          (y + 0.5 - kHeight / 2.0) / kFocal * kPlaneZ};
}

// Varies within a few pixels, so that inpainting cannot guess it.
cv::Vec3f PlaneColour(const cv::Point2d& p) {
  return cv::Vec3f(static_cast<float>(0.5 + 0.4 * std::sin(8 * p.x)),
                   static_cast<float>(0.5 + 0.4 * std::cos(6 * p.y)),
                   static_cast<float>(0.5 + 0.4 * std::sin(5 * (p.x + p.y))));
}

// A static textured plane seen from cameras at `centres` (times 0, 1, ...);
// `hole(frame, world point)` says which pixels to mask. Holes hold NaN.
PriorClip PlaneClip(const std::vector<float>& centres,
                    const std::function<bool(int, const cv::Point2d&)>& hole) {
  PriorClip clip;
  clip.name = "step1_dir0";
  for (std::size_t i = 0; i < centres.size(); ++i) {
    cv::Mat rgb(kHeight, kWidth, CV_32FC3), mask(kHeight, kWidth, CV_8UC1);
    cv::Mat depth(kHeight, kWidth, CV_32FC1, cv::Scalar(kPlaneZ));
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const cv::Point2d p = WorldPoint(centres[i], x, y);
        const bool masked = hole(static_cast<int>(i), p);
        mask.at<uint8_t>(y, x) = masked ? 255 : 0;
        rgb.at<cv::Vec3f>(y, x) = masked ? cv::Vec3f::all(NAN) : PlaneColour(p);
        if (masked) depth.at<float>(y, x) = NAN;
      }
    }
    clip.frames.push_back(rgb);
    clip.masks.push_back(mask);
    clip.depth.push_back(depth);
    clip.cameras.push_back(PlaneCamera(centres[i]));
    clip.times.push_back(static_cast<int>(i));
    clip.references.push_back(
        cv::Mat(kHeight, kWidth, CV_32FC3, cv::Scalar::all(0.25)));
    clip.reference_cameras.push_back(PlaneCamera(0));
  }
  return clip;
}

bool AllFiniteInUnitRange(const cv::Mat& m) {
  if (!cv::checkRange(m, true)) return false;
  double lo = 0, hi = 0;
  cv::minMaxLoc(m.reshape(1), &lo, &hi);
  return lo >= 0 && hi <= 1;
}

// Unmasked pixels bit-identical (NaN compares unequal, memcmp does not).
void ExpectUnmaskedIdentical(const cv::Mat& expected, const cv::Mat& actual,
                             const cv::Mat& mask) {
  ASSERT_EQ(actual.type(), expected.type());
  ASSERT_EQ(actual.size(), expected.size());
  int differ = 0;
  for (int y = 0; y < mask.rows; ++y) {
    for (int x = 0; x < mask.cols; ++x) {
      if (mask.at<uint8_t>(y, x)) continue;
      differ += std::memcmp(expected.ptr(y, x), actual.ptr(y, x),
                            expected.elemSize()) != 0;
    }
  }
  EXPECT_EQ(differ, 0);
}

TEST(GeometryPriorTest, KeepsUnmaskedPixelsAndFillsEveryMaskedOne) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 1), z(1, 3);
  PriorClip clip =
      PlaneClip({0, 0.1f, 0.2f, 0.3f}, [](int, auto&) { return false; });
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        // Rough depth and colour on purpose; frame 2 keeps an empty mask.
        const bool masked = i != 2 && (u(rng) < 0.3f || (x > 20 && y > 10));
        clip.masks[i].at<uint8_t>(y, x) = masked ? 255 : 0;
        clip.frames[i].at<cv::Vec3f>(y, x) =
            masked ? cv::Vec3f::all(NAN) : cv::Vec3f(u(rng), u(rng), u(rng));
        clip.depth[i].at<float>(y, x) = masked ? NAN : z(rng);
      }
    }
  }
  GeometryPrior prior;
  const PriorResult result = prior.Fill(clip);
  EXPECT_EQ(result.prior, "geometry");
  EXPECT_TRUE(result.note.empty());
  ASSERT_EQ(result.frames.size(), clip.frames.size());
  ASSERT_EQ(result.depth.size(), clip.frames.size());
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    ExpectUnmaskedIdentical(clip.frames[i], result.frames[i], clip.masks[i]);
    ExpectUnmaskedIdentical(clip.depth[i], result.depth[i], clip.masks[i]);
    EXPECT_TRUE(AllFiniteInUnitRange(result.frames[i]));
    EXPECT_TRUE(cv::checkRange(result.depth[i], true, nullptr, 0, 1e9));
  }
  // A frame with nothing to fill comes back as it was, NaN-free input or not.
  EXPECT_EQ(cv::norm(result.frames[2], clip.frames[2], cv::NORM_INF), 0);
}

TEST(GeometryPriorTest, FillsAHoleWithWhatAnotherFrameSaw) {
  // 1.95 pixels of shift per frame: the splat lands between pixels.
  const std::vector<float> centres = {0, 0.13f, 0.26f};
  const auto hole = [](int frame, const cv::Point2d& p) {
    return frame == 1 && std::abs(p.x + 0.1) < 0.25 && std::abs(p.y) < 0.25;
  };
  const PriorClip clip = PlaneClip(centres, hole);
  const int holes = cv::countNonZero(clip.masks[1]);
  ASSERT_GT(holes, 40);

  GeometryPrior prior;
  const PriorResult result = prior.Fill(clip);
  double max_error = 0, sum_error = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      if (!clip.masks[1].at<uint8_t>(y, x)) continue;
      const cv::Vec3f truth = PlaneColour(WorldPoint(centres[1], x, y));
      const double error =
          cv::norm(result.frames[1].at<cv::Vec3f>(y, x) - truth, cv::NORM_INF);
      max_error = std::max(max_error, error);
      sum_error += error;
      EXPECT_NEAR(result.depth[1].at<float>(y, x), kPlaneZ, 1e-3);
    }
  }
  EXPECT_LT(max_error, 0.06);
  EXPECT_LT(sum_error / holes, 0.02);
}

TEST(GeometryPriorTest, InventsUnseenContentOnceForEveryFrame) {
  // 6 pixels of shift per frame; the region W (x in [-0.45, 0.12)) is masked
  // in every frame: inside frame 1 (the reference), at frame 2's left edge,
  // where inpainting frame 2 alone would see only W's right side.
  const std::vector<float> centres = {0, 0.4f, 0.8f};
  const auto hole = [](int, const cv::Point2d& p) {
    return p.x >= -0.45 && p.x < 0.12 && std::abs(p.y) < 0.45;
  };
  const PriorClip clip = PlaneClip(centres, hole);
  ASSERT_GT(cv::countNonZero(clip.masks[2].colRange(0, 1)), 0);

  GeometryPrior prior;
  const PriorResult result = prior.Fill(clip);
  for (int other : {0, 2}) {
    SCOPED_TRACE("frame " + std::to_string(other));
    const int shift = other == 0 ? -6 : 6;  // reference x = x + shift
    double max_difference = 0;
    int compared = 0;
    // The whole hole: the mesh warp bridges nothing across it.
    const cv::Mat& interior = clip.masks[other];
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const int xr = x + shift;
        if (!interior.at<uint8_t>(y, x) || xr < 0 || xr >= kWidth) continue;
        ASSERT_TRUE(clip.masks[1].at<uint8_t>(y, xr));
        max_difference = std::max(
            max_difference, cv::norm(result.frames[other].at<cv::Vec3f>(y, x) -
                                         result.frames[1].at<cv::Vec3f>(y, xr),
                                     cv::NORM_INF));
        ++compared;
      }
    }
    EXPECT_GT(compared, 20);
    EXPECT_LT(max_difference, 0.02);
    EXPECT_TRUE(AllFiniteInUnitRange(result.frames[other]));
  }
}

// Frame `i` of a clip masked over `region` (NaN under the mask, as holes
// hold arbitrary values).
void MaskRegion(PriorClip* clip, std::size_t i, const cv::Rect& region) {
  clip->masks[i](region).setTo(255);
  clip->frames[i](region).setTo(cv::Scalar::all(NAN));
}

// The geometry prior's fill of `clip`, with what it logged in *log.
PriorResult FillLogged(const PriorClip& clip, std::string* log) {
  std::ostringstream stream;
  SetLogSink(&stream);
  PriorResult result = GeometryPrior().Fill(clip);
  SetLogSink(nullptr);
  *log = stream.str();
  return result;
}

// A moving object (white, in front of the plane) painted into frame `i` of
// a clip over `region`, marked in the clip's moving masks.
void PaintMovingObject(PriorClip* clip, std::size_t i, const cv::Rect& region) {
  if (clip->moving.empty()) {
    for (const cv::Mat& m : clip->masks)
      clip->moving.push_back(cv::Mat::zeros(m.size(), CV_8UC1));
  }
  clip->frames[i](region).setTo(cv::Scalar::all(1));
  clip->depth[i](region).setTo(kPlaneZ * 0.9);
  clip->masks[i](region).setTo(0);
  clip->moving[i](region).setTo(255);
}

// Mean over `region` of the distance between frame `i`'s colour and white.
double MeanDistanceToWhite(const PriorResult& result, std::size_t i,
                           const cv::Rect& region) {
  double sum = 0;
  for (int y = region.y; y < region.br().y; ++y)
    for (int x = region.x; x < region.br().x; ++x)
      sum +=
          cv::norm(result.frames[i].at<cv::Vec3f>(y, x) - cv::Vec3f(1, 1, 1));
  return sum / region.area();
}

TEST(GeometryPriorTest, DoesNotCopyMovingContentAcrossTime) {
  // One camera, three times. At time 0 a moving object covers `region`; at
  // time 1 the region is a hole; at time 2 it shows the plane. The object
  // is elsewhere at time 1, so the hole must come from time 2.
  const cv::Rect region(10, 8, 6, 6);
  PriorClip clip = PlaneClip({0, 0, 0}, [](int, auto&) { return false; });
  MaskRegion(&clip, 1, region);
  PaintMovingObject(&clip, 0, region);

  const PriorResult result = GeometryPrior().Fill(clip);
  // Time 0's static pixels around the region may bridge its corners as warp
  // cracks (interpolated); the rest is time 2's plane, exactly.
  double sum_error = 0;
  int exact = 0;
  for (int y = region.y; y < region.br().y; ++y) {
    for (int x = region.x; x < region.br().x; ++x) {
      const cv::Vec3f truth = PlaneColour(WorldPoint(0, x, y));
      const double error =
          cv::norm(result.frames[1].at<cv::Vec3f>(y, x) - truth, cv::NORM_INF);
      sum_error += error;
      exact += error < 1e-4;
    }
  }
  EXPECT_LT(sum_error / region.area(), 0.1);
  EXPECT_GT(exact, region.area() / 2);
  EXPECT_GT(MeanDistanceToWhite(result, 1, region), 0.5);

  // Without the moving masks the object (time 0, nearest first) is copied.
  PriorClip unmarked = clip;
  unmarked.moving.clear();
  EXPECT_LT(MeanDistanceToWhite(GeometryPrior().Fill(unmarked), 1, region),
            1e-4);
}

TEST(GeometryPriorTest, InpaintsFromStaticPixelsOnly) {
  // A hole that no frame saw, beside a moving object in every frame: the
  // invented content continues the plane, not the object.
  const cv::Rect hole_region(10, 8, 6, 8), object(16, 6, 8, 12);
  PriorClip clip = PlaneClip({0, 0, 0}, [](int, auto&) { return false; });
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    MaskRegion(&clip, i, hole_region);
    PaintMovingObject(&clip, i, object);
  }
  PriorClip unmarked = clip;
  unmarked.moving.clear();
  const PriorResult result = GeometryPrior().Fill(clip);
  const PriorResult control = GeometryPrior().Fill(unmarked);
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    const double marked = MeanDistanceToWhite(result, i, hole_region);
    const double bled = MeanDistanceToWhite(control, i, hole_region);
    EXPECT_GT(marked, bled + 0.1);
    // The hole's depth comes from the plane, not from the nearer object.
    for (int y = hole_region.y; y < hole_region.br().y; ++y)
      for (int x = hole_region.x; x < hole_region.br().x; ++x)
        EXPECT_NEAR(result.depth[i].at<float>(y, x), kPlaneZ, 1e-3);
    ExpectUnmaskedIdentical(clip.frames[i], result.frames[i], clip.masks[i]);
  }
}

TEST(GeometryPriorTest, AHoleNoFrameSawLiesOnTheLayoutInItsColour) {
  // A wide hole in every frame of a still camera: nothing saw it. With a
  // layout behind the plane (z = 3), the hole's content lies on it and,
  // away from the hole's edge, takes its colour; a layout in front of the
  // plane (z = 1) does not pull the content forward.
  const cv::Rect hole(4, 4, 24, 16);
  const cv::Point centre(16, 12);
  const cv::Vec3f layout_colour(0.9f, 0.05f, 0.1f);
  PriorClip clip = PlaneClip({0, 0, 0}, [](int, auto&) { return false; });
  for (std::size_t i = 0; i < clip.frames.size(); ++i)
    MaskRegion(&clip, i, hole);
  const auto with_layout = [&](float z) {
    PriorClip c = clip;
    for (std::size_t i = 0; i < c.frames.size(); ++i) {
      c.layout_depth.emplace_back(kHeight, kWidth, CV_32FC1, cv::Scalar(z));
      c.layout_rgb.emplace_back(
          kHeight, kWidth, CV_32FC3,
          cv::Scalar(layout_colour[0], layout_colour[1], layout_colour[2]));
    }
    return c;
  };
  const PriorResult behind = GeometryPrior().Fill(with_layout(3));
  const PriorResult in_front = GeometryPrior().Fill(with_layout(1));
  const PriorResult none = GeometryPrior().Fill(clip);
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_NEAR(behind.depth[i].at<float>(centre), 3, 1e-5);
    EXPECT_NEAR(in_front.depth[i].at<float>(centre), kPlaneZ, 1e-5);
    EXPECT_NEAR(none.depth[i].at<float>(centre), kPlaneZ, 1e-5);
    EXPECT_LT(cv::norm(behind.frames[i].at<cv::Vec3f>(centre) - layout_colour),
              0.05);
    EXPECT_GT(cv::norm(none.frames[i].at<cv::Vec3f>(centre) - layout_colour),
              0.3);
    // At the hole's edge the inpainted colour still weighs (the fade).
    const cv::Point edge(hole.x, centre.y);
    EXPECT_GT(cv::norm(behind.frames[i].at<cv::Vec3f>(edge) - layout_colour),
              0.1);
    ExpectUnmaskedIdentical(clip.frames[i], behind.frames[i], clip.masks[i]);
    EXPECT_TRUE(AllFiniteInUnitRange(behind.frames[i]));
  }
}

TEST(GeometryPriorTest, AFrameOfOnlyMovingContentKeepsItAndFillsGrey) {
  // Every frame: the left half a hole, the right half a moving object, so
  // nothing static is known anywhere.
  const cv::Rect left(0, 0, kWidth / 2, kHeight),
      right(kWidth / 2, 0, kWidth / 2, kHeight);
  PriorClip clip = PlaneClip({0, 0.1f}, [](int, auto&) { return false; });
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    MaskRegion(&clip, i, left);
    PaintMovingObject(&clip, i, right);
  }
  std::string log;
  const PriorResult result = FillLogged(clip, &log);
  EXPECT_NE(log.find("only moving content"), std::string::npos) << log;
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    ExpectUnmaskedIdentical(clip.frames[i], result.frames[i], clip.masks[i]);
    EXPECT_EQ(cv::norm(result.frames[i](left),
                       cv::Mat(left.size(), CV_32FC3, cv::Scalar::all(0.5)),
                       cv::NORM_INF),
              0);
  }
}

TEST(GeometryPriorTest, AClipMaskedEverywhereComesBackFinite) {
  const PriorClip clip =
      PlaneClip({0, 0.1f, 0.2f}, [](int, auto&) { return true; });
  std::string log;
  const PriorResult result = FillLogged(clip, &log);
  EXPECT_NE(log.find("masked everywhere"), std::string::npos) << log;
  for (std::size_t i = 0; i < clip.frames.size(); ++i) {
    EXPECT_TRUE(AllFiniteInUnitRange(result.frames[i]));
    EXPECT_TRUE(cv::checkRange(result.depth[i], true, nullptr, 0, 1e9));
  }
}

TEST(PriorClipTest, CheckNamesTheFieldThatDisagrees) {
  const auto hole = [](int, const cv::Point2d& p) { return p.x > 0; };
  PriorClip clip = PlaneClip({0, 0.1f}, hole);
  EXPECT_NO_THROW(clip.Check());

  PriorClip fewer_masks = clip;
  fewer_masks.masks.pop_back();
  try {
    fewer_masks.Check();
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "masks");
    EXPECT_EQ(e.value(), "1");
  }

  PriorClip smaller_depth = clip;
  smaller_depth.depth[1] = cv::Mat(12, 16, CV_32FC1, cv::Scalar(1));
  try {
    smaller_depth.Check();
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "depth[1]");
    EXPECT_NE(std::string(e.what()).find("32x24"), std::string::npos);
  }

  PriorClip wrong_type = clip;
  wrong_type.masks[0] = cv::Mat(kHeight, kWidth, CV_32FC1, cv::Scalar(0));
  EXPECT_THROW(wrong_type.Check(), Error);
  PriorClip no_times = clip;
  no_times.times.clear();
  EXPECT_THROW(no_times.Check(), Error);
  EXPECT_THROW(PriorClip().Check(), Error);
  PriorClip short_moving = clip;
  short_moving.moving.push_back(cv::Mat::zeros(kHeight, kWidth, CV_8UC1));
  try {
    short_moving.Check();
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "moving");
  }
  PriorClip layout_without_colour = clip;
  for (int i = 0; i < 2; ++i)
    layout_without_colour.layout_depth.emplace_back(kHeight, kWidth, CV_32FC1,
                                                    cv::Scalar(3));
  try {
    layout_without_colour.Check();
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "layout_rgb");
  }
}

TEST(CompositeTest, SelectsPerPixelAndRejectsMismatches) {
  const cv::Mat warped(2, 2, CV_32FC3, cv::Scalar::all(0.1));
  const cv::Mat filled(2, 2, CV_32FC3, cv::Scalar::all(0.9));
  cv::Mat mask(2, 2, CV_8UC1, cv::Scalar(0));
  mask.at<uint8_t>(1, 0) = 255;
  const cv::Mat out = Composite(warped, filled, mask);
  EXPECT_EQ(out.at<cv::Vec3f>(1, 0), cv::Vec3f::all(0.9f));
  EXPECT_EQ(out.at<cv::Vec3f>(0, 0), cv::Vec3f::all(0.1f));
  EXPECT_THROW(Composite(warped, cv::Mat(3, 2, CV_32FC3), mask), Error);
  EXPECT_THROW(Composite(warped, filled, cv::Mat(2, 2, CV_32FC1)), Error);
}

// --- CommandPrior, with tests/pano/fake_prior.cc as the model -------------

std::string FakeCommand(const std::string& mode) {
  return "'" + std::string(PANO4D_FAKE_PRIOR) + "' " + mode + " {in} {out}";
}

PriorClip HoleClip() {
  return PlaneClip({0, 0.13f, 0.26f}, [](int frame, const cv::Point2d& p) {
    return frame != 0 && std::abs(p.x - 0.1) < 0.2 && std::abs(p.y) < 0.2;
  });
}

TEST(CommandPriorTest, RoundTripFillsMasksWithTheCommandsOutput) {
  testing::TempDir dir;
  const PriorClip clip = HoleClip();
  CommandPrior prior(FakeCommand("fill"), dir.path(),
                     std::make_unique<GeometryPrior>());
  const PriorResult result = prior.Fill(clip);
  EXPECT_EQ(result.prior, "command");
  EXPECT_TRUE(result.note.empty()) << result.note;
  ASSERT_EQ(result.frames.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    ExpectUnmaskedIdentical(clip.frames[i], result.frames[i], clip.masks[i]);
    int magenta = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        magenta += clip.masks[i].at<uint8_t>(y, x) &&
                   result.frames[i].at<cv::Vec3f>(y, x) == cv::Vec3f(1, 0, 1);
      }
    }
    EXPECT_EQ(magenta, cv::countNonZero(clip.masks[i]));
  }
  const fs::path in = dir / "step1_dir0" / "in";
  for (const char* folder : {"frames", "masks", "references"}) {
    EXPECT_TRUE(fs::is_regular_file(in / folder / "00002.png")) << folder;
  }
  const Json meta = ReadJson(in / "meta.json");
  EXPECT_EQ(meta.at("count"), 3);
  EXPECT_EQ(meta.at("width"), kWidth);
  EXPECT_EQ(meta.at("height"), kHeight);
  EXPECT_EQ(meta.at("clip"), "step1_dir0");
  EXPECT_EQ(meta.at("times"), Json({0, 1, 2}));
  ASSERT_EQ(meta.at("cameras").size(), 3u);
  EXPECT_EQ(meta.at("cameras")[1].at("width"), kWidth);
  EXPECT_EQ(meta.at("reference_cameras").size(), 3u);
}

struct FailureCase {
  std::string mode;
  std::string problem;  // what the note must say
};

class CommandPriorFailureTest : public ::testing::TestWithParam<FailureCase> {};

TEST_P(CommandPriorFailureTest, FallsBackToTheGeometryPriorAndSaysWhy) {
  testing::TempDir dir;
  const PriorClip clip = HoleClip();
  CommandPrior prior(FakeCommand(GetParam().mode), dir.path(),
                     std::make_unique<GeometryPrior>());
  std::ostringstream log;
  SetLogSink(&log);
  const PriorResult result = prior.Fill(clip);
  SetLogSink(nullptr);

  EXPECT_EQ(result.prior, "geometry");
  EXPECT_NE(result.note.find(GetParam().problem), std::string::npos)
      << result.note;
  EXPECT_NE(result.note.find("step1_dir0"), std::string::npos) << result.note;
  EXPECT_NE(log.str().find("falling back to the geometry prior"),
            std::string::npos)
      << log.str();
  EXPECT_NE(log.str().find(GetParam().mode + " {in} {out}"), std::string::npos)
      << log.str();
  ASSERT_EQ(result.frames.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    ExpectUnmaskedIdentical(clip.frames[i], result.frames[i], clip.masks[i]);
    EXPECT_TRUE(AllFiniteInUnitRange(result.frames[i]));
  }
  // Nothing lost: the inputs stay for inspection.
  EXPECT_TRUE(
      fs::is_regular_file(dir / "step1_dir0" / "in" / "frames" / "00000.png"));
  EXPECT_TRUE(fs::is_regular_file(dir / "step1_dir0" / "in" / "meta.json"));
}

INSTANTIATE_TEST_SUITE_P(
    Modes, CommandPriorFailureTest,
    ::testing::Values(
        FailureCase{"fail", "status 3: \"fake prior: failing on request\""},
        FailureCase{"small", "is 16x12, expected 32x24"},
        FailureCase{"few", "found 2 of 3 frames"},
        FailureCase{"garbage", "00000.png: cannot be decoded"}),
    [](const auto& info) { return info.param.mode; });

TEST(CommandPriorTest, WithoutAFallbackAFailureIsAnError) {
  testing::TempDir dir;
  CommandPrior prior(FakeCommand("fail"), dir.path(), nullptr);
  try {
    prior.Fill(HoleClip());
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("status 3"), std::string::npos)
        << e.what();
  }
}

// A command that hangs (here a shell that starts a sleep in the background
// and waits for it) is stopped at its time limit with everything it
// started, and the CPU prior fills the clip.
TEST(CommandPriorTest, AHangingCommandIsStoppedAtItsTimeLimitWithItsChildren) {
  testing::TempDir dir;
  const fs::path pid_file = dir / "sleep.pid";
  CommandPrior prior(
      "sleep 60 & echo $! > '" + pid_file.string() + "'; wait # {in} {out}",
      dir / "work", std::make_unique<GeometryPrior>(),
      /*timeout_seconds=*/0.5);
  const auto start = std::chrono::steady_clock::now();
  const PriorResult result = prior.Fill(HoleClip());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  EXPECT_EQ(result.prior, "geometry");
  EXPECT_NE(result.note.find("stopped at its time limit of 0.5 s"),
            std::string::npos)
      << result.note;
  // Nothing printed: the note quotes no line (not the log's command line).
  EXPECT_EQ(result.note.find("\": \""), std::string::npos) << result.note;
  EXPECT_EQ(result.note.find("/bin/sh"), std::string::npos) << result.note;
  EXPECT_LT(seconds, 10.0);  // the limit is what ended it, not the sleep
  // The sleep the shell started went with it.
  std::ifstream in(pid_file);
  pid_t sleeper = 0;
  ASSERT_TRUE(in >> sleeper);
  // Gone, or a zombie that nobody has reaped yet (a container's init may
  // take its time): either way no longer running.
  std::ifstream stat("/proc/" + std::to_string(sleeper) + "/stat");
  std::string pid, name, state;
  if (stat >> pid >> name >> state) {
    EXPECT_EQ(state, "Z") << "pid " << sleeper << " still runs";
  }
}

TEST(CommandPriorTest, RejectsATemplateWithoutItsFolders) {
  testing::TempDir dir;
  try {
    CommandPrior("model --out {out}", dir.path(), nullptr);
    ADD_FAILURE() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("{in}"), std::string::npos);
  }
  EXPECT_THROW(CommandPrior("model {in}", dir.path(), nullptr), Error);
}

}  // namespace
}  // namespace pano4d
