#include "src/gs/init.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "src/datasets/synth_cameras.h"
#include "src/render/rasterizer.h"
#include "tests/support/synth_video.h"

namespace pano4d {
namespace {

using testing::DenseSynthVideo;
constexpr int kWidth = DenseSynthVideo::kWidth;
constexpr int kHeight = DenseSynthVideo::kHeight;
constexpr int kFrames = DenseSynthVideo::kFrames;

// The dense synthetic video (a box that slides and turns, a ball that
// rolls and a bending tube) as the trainer's views, with its depth.
std::vector<TrainingView> FilmSyntheticScene() {
  const DenseSynthVideo video = testing::FilmDenseSynthVideo(false);
  std::vector<TrainingView> views;
  for (int t = 0; t < kFrames; ++t) {
    const synth::RenderedFrame& frame = video.frames[t];
    TrainingView v;
    v.name = "frame" + std::to_string(t);
    v.time = t;
    v.camera = RasterCamera::FromPosed(video.cameras[t]);
    const cv::Mat& rgb = frame.rgb.mat();
    v.rgb.assign(rgb.ptr<float>(), rgb.ptr<float>() + rgb.total() * 3);
    v.depth.assign(frame.depth.ptr<float>(),
                   frame.depth.ptr<float>() + frame.depth.total());
    for (auto it = frame.dynamic.begin<std::uint8_t>();
         it != frame.dynamic.end<std::uint8_t>(); ++it)
      v.dynamic.push_back(*it ? 1 : 0);
    views.push_back(std::move(v));
  }
  return views;
}

struct Coverage {
  double covered = 0;   // share of moving surface points with a Gaussian near
  double floating = 0;  // share of dynamic Gaussians a view sees through
};

// Each view's moving pixels (every 2nd) as surface points, against the
// initial scene composed at that view's time: covered when a dynamic
// Gaussian's centre lies within `radius`. And the dynamic Gaussians, posed
// at each view's time, that the view sees more than 5% in front of its
// depth: floaters the initialisation put where that view shows nothing.
Coverage Measure(const GaussianScene& scene,
                 const std::vector<TrainingView>& views, double radius) {
  Coverage c;
  std::int64_t points = 0, covered = 0, posed = 0, floating = 0;
  GaussianModel composed;
  const std::size_t first = scene.statics.size();
  for (const TrainingView& v : views) {
    scene.ComposeAt(v.time, &composed);
    std::vector<Eigen::Vector3f> means;
    for (std::size_t i = first; i < composed.size(); ++i) {
      const Eigen::Vector3f mu(composed.means[i * 3], composed.means[i * 3 + 1],
                               composed.means[i * 3 + 2]);
      means.push_back(mu);
      const Eigen::Vector3f cam = v.camera.rotation * mu + v.camera.translation;
      if (!(cam.z() > 0)) continue;
      const int x = static_cast<int>(
          std::floor(v.camera.fx * cam.x() / cam.z() + v.camera.cx));
      const int y = static_cast<int>(
          std::floor(v.camera.fy * cam.y() / cam.z() + v.camera.cy));
      if (x < 0 || y < 0 || x >= kWidth || y >= kHeight) continue;
      const float depth = v.depth[static_cast<std::size_t>(y) * kWidth + x];
      if (!(depth > 0)) continue;
      ++posed;
      if (cam.z() < 0.95f * depth) ++floating;
    }
    for (int y = 0; y < kHeight; y += 2) {
      for (int x = 0; x < kWidth; x += 2) {
        const std::size_t p = static_cast<std::size_t>(y) * kWidth + x;
        if (!v.dynamic[p] || !(v.depth[p] > 0)) continue;
        const float z = v.depth[p];
        const Eigen::Vector3f cam((x + 0.5f - v.camera.cx) / v.camera.fx * z,
                                  (y + 0.5f - v.camera.cy) / v.camera.fy * z,
                                  z);
        const Eigen::Vector3f world =
            v.camera.rotation.transpose() * (cam - v.camera.translation);
        ++points;
        for (const Eigen::Vector3f& mu : means) {
          if ((mu - world).norm() < radius) {
            ++covered;
            break;
          }
        }
      }
    }
  }
  c.covered = static_cast<double>(covered) / std::max<std::int64_t>(points, 1);
  c.floating = static_cast<double>(floating) / std::max<std::int64_t>(posed, 1);
  return c;
}

// The initial motion (bases from lifted flow tracks, k-means and one
// Procrustes fit per cluster and frame) carries the canonical frame's
// moving Gaussians through the clip: at every time most of what the view
// shows of the moving objects has a Gaussian near, and few hang where the
// view sees through them. The static part has no moving pixels in it.
TEST(InitTest, InitialMotionCarriesTheMovingObjectsThroughTheClip) {
  const std::vector<TrainingView> views = FilmSyntheticScene();
  // The visible surface only: this measures the motion. The Gaussians
  // seeded behind it (dynamic_thickness, below) overshoot objects that are
  // not round, which some views see as free space (with them: 0.246
  // floating).
  InitOptions options;
  options.dynamic_thickness = 0;
  InitReport report;
  const GaussianScene scene =
      InitializeScene(views, kFrames, options, /*seed=*/0, &report);
  ASSERT_GT(scene.dynamics.size(), 0u);
  ASSERT_TRUE(scene.has_motion());
  EXPECT_EQ(scene.canonical_time, kFrames / 2);
  EXPECT_GT(report.tracks, 0);
  EXPECT_GT(report.track_coverage, 0.5);
  EXPECT_EQ(scene.logits.size(), scene.dynamics.size() * scene.bases.num_bases);

  const Coverage c = Measure(scene, views, 3 * report.voxel_size);
  RecordProperty("covered", std::to_string(c.covered));
  RecordProperty("floating", std::to_string(c.floating));
  // Measured: 0.933 covered, 0.203 floating (identity bases: 0.424 and
  // 0.599). The floaters are the tracks' drift far from the canonical time
  // (docs/experiments/2026-11-23-moving-pixels-diagnosis.md), which the fit
  // corrects only in
  // part. With the flow stopped at half resolution (OpenCV DIS's preset)
  // the tracks drifted more: 0.918 and 0.257, which the floating bound
  // fails.
  EXPECT_GT(c.covered, 0.85);
  EXPECT_LT(c.floating, 0.23);
  // Against no motion at all (every basis the identity at every time), the
  // fitted bases cover more and float less.
  GaussianScene frozen = scene;
  frozen.bases.Reset(scene.bases.num_bases, scene.bases.num_times);
  const Coverage f = Measure(frozen, views, 3 * report.voxel_size);
  RecordProperty("covered_frozen", std::to_string(f.covered));
  RecordProperty("floating_frozen", std::to_string(f.floating));
  EXPECT_GT(c.covered, f.covered + 0.1) << f.covered;
  EXPECT_LT(c.floating, f.floating - 0.05) << f.floating;

  // Without motion (K = 0) every pixel is static: no dynamic Gaussians,
  // no bases, and more static points.
  InitOptions still = options;
  still.num_bases = 0;
  InitReport still_report;
  const GaussianScene static_scene =
      InitializeScene(views, kFrames, still, /*seed=*/0, &still_report);
  EXPECT_EQ(static_scene.dynamics.size(), 0u);
  EXPECT_FALSE(static_scene.has_motion());
  EXPECT_GT(still_report.static_points_raw, report.static_points_raw);
}

struct Silhouette {
  double covered = 0;  // share of the true moving pixels the Gaussians cover
  double spilled = 0;  // share of what they cover outside the true mask
};

// Validation camera `index` of the dense video's scene (75 degrees aside
// from the training arc) and the moving mask the generator renders for it
// at `time`.
struct SideCamera {
  PosedCamera camera;
  cv::Mat moving;  // CV_8UC1, 255 on moving objects
};

SideCamera FilmFromTheSide(int index, int time) {
  const synth::Scene truth =
      synth::BuildScene(DenseSynthVideo::kSeed, /*is_static=*/false);
  const double f = 0.9 * kWidth;
  const Camera intrinsics{CameraModelId::kPinhole,
                          kWidth,
                          kHeight,
                          {f, f, kWidth / 2.0, kHeight / 2.0}};
  SideCamera side;
  side.camera = synth::ValidationCamera(truth, intrinsics, index);
  side.moving = synth::RenderFrame(truth, side.camera, time / (kFrames - 1.0),
                                   /*shade=*/false, /*keep_surface=*/false)
                    .dynamic;
  return side;
}

// The initial dynamic Gaussians at the canonical time, made nearly opaque
// (each covers the pixels within about one sigma of its centre), seen by
// `side` against its true moving mask. Spill counts beyond 2 pixels of
// the true mask.
Silhouette SideView(const GaussianScene& scene, const SideCamera& side) {
  GaussianModel composed;
  scene.ComposeAt(scene.canonical_time, &composed);
  for (std::size_t i = 0; i < scene.statics.size(); ++i)
    composed.opacities[i] = InverseSigmoid(1e-6f);  // out of the picture
  for (std::size_t i = scene.statics.size(); i < composed.size(); ++i)
    composed.opacities[i] = InverseSigmoid(0.99f);
  Rasterizer rasterizer;
  RenderOutput out;
  rasterizer.Render(composed, RasterCamera::FromPosed(side.camera), {}, &out);

  cv::Mat near_mask;
  cv::dilate(side.moving, near_mask,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 5)));
  std::int64_t moving = 0, covered = 0, drawn = 0, spilled = 0;
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const bool in = side.moving.at<std::uint8_t>(y, x) != 0;
      const bool on =
          out.alpha[static_cast<std::size_t>(y) * kWidth + x] > 0.5f;
      moving += in;
      covered += in && on;
      drawn += on;
      spilled += on && near_mask.at<std::uint8_t>(y, x) == 0;
    }
  }
  return {static_cast<double>(covered) / std::max<std::int64_t>(moving, 1),
          static_cast<double>(spilled) / std::max<std::int64_t>(drawn, 1)};
}

// The canonical frame shows one side of each moving object. Without a
// prior its Gaussians form a shell of that side, which a camera 75
// degrees aside sees narrower than the object; seeded through the depth
// that the mask's local width suggests (InitOptions::dynamic_thickness),
// they cover the object's silhouette there, spilling a little more past
// it (objects that are not round) but not much.
// A tracker's tracks (learned priors) are followed instead of flow: exact
// tracks of the canonical frame's moving pixels, hidden where another
// surface is in front, carry the moving objects at least as well as the
// chained DIS flow does.
TEST(InitTest, GivenTracksAreFollowedInsteadOfFlow) {
  const std::vector<TrainingView> views = FilmSyntheticScene();
  using V = testing::DenseSynthVideo;
  const synth::Scene scene = synth::BuildScene(V::kSeed, false);
  const testing::DenseSynthVideo video = testing::FilmDenseSynthVideo(false);
  const int canonical = kFrames / 2;
  const synth::RenderedFrame surface =
      synth::RenderFrame(scene, video.cameras[canonical],
                         canonical / (kFrames - 1.0), false, true);
  Tracks2D tracks;
  tracks.num_times = kFrames;
  for (int y = 0; y < kHeight; y += 3) {
    for (int x = 0; x < kWidth; x += 3) {
      const std::size_t i = static_cast<std::size_t>(y) * kWidth + x;
      if (!views[canonical].dynamic[i] || surface.part[i] < 0) continue;
      for (int t = 0; t < kFrames; ++t) {
        const synth::PartPoses poses = synth::PosesAt(scene, t / (kFrames - 1.0));
        const Eigen::Vector3d cam =
            video.cameras[t].cam_from_world *
            (poses.world_from_part[surface.part[i]] * surface.local[i]);
        const Camera& c = video.cameras[t].camera;
        const double u = c.focal_x() * cam.x() / cam.z() + c.principal_x();
        const double v = c.focal_y() * cam.y() / cam.z() + c.principal_y();
        bool seen = u >= 0 && v >= 0 && u < kWidth && v < kHeight;
        if (seen) {
          const float d = views[t].depth[static_cast<std::size_t>(v) * kWidth +
                                         static_cast<std::size_t>(u)];
          seen = d > 0 && cam.z() < 1.03 * d;
        }
        tracks.pixels.emplace_back(static_cast<float>(u), static_cast<float>(v));
        tracks.valid.push_back(seen ? 1 : 0);
      }
    }
  }
  ASSERT_GT(tracks.size(), static_cast<std::size_t>(kMinGivenTracks));
  InitOptions options;
  options.dynamic_thickness = 0;
  InitReport report;
  const GaussianScene given = InitializeScene(views, kFrames, options,
                                              /*seed=*/0, &report, &tracks);
  EXPECT_EQ(report.track_flow, "tracker");
  EXPECT_EQ(report.tracks, static_cast<std::int64_t>(tracks.size()));
  const Coverage c = Measure(given, views, 3 * report.voxel_size);
  RecordProperty("covered", std::to_string(c.covered));
  RecordProperty("floating", std::to_string(c.floating));
  // Measured: 0.983 covered, 0.078 floating (DIS flow, above: 0.933, 0.203).
  EXPECT_GT(c.covered, 0.95);
  EXPECT_LT(c.floating, 0.15);
  // Too few tracks (none at the canonical time): flow as before.
  Tracks2D empty;
  empty.num_times = kFrames;
  InitReport fallback;
  InitializeScene(views, kFrames, options, 0, &fallback, &empty);
  EXPECT_EQ(fallback.track_flow, "DIS");
}

TEST(InitTest, MovingObjectsStartSolidFromTheSide) {
  const std::vector<TrainingView> views = FilmSyntheticScene();
  InitOptions shell;
  shell.dynamic_thickness = 0;
  InitReport shell_report, solid_report;
  const GaussianScene shell_scene =
      InitializeScene(views, kFrames, shell, /*seed=*/0, &shell_report);
  const GaussianScene solid_scene =
      InitializeScene(views, kFrames, InitOptions{}, /*seed=*/0, &solid_report);
  EXPECT_GT(solid_report.dynamic_points_raw,
            2 * shell_report.dynamic_points_raw);
  EXPECT_EQ(solid_report.static_points_raw, shell_report.static_points_raw);
  ASSERT_EQ(shell_scene.canonical_time, solid_scene.canonical_time);
  for (int index : {1, 2}) {
    const SideCamera side = FilmFromTheSide(index, solid_scene.canonical_time);
    const Silhouette a = SideView(shell_scene, side);
    const Silhouette b = SideView(solid_scene, side);
    const std::string camera = std::to_string(index);
    RecordProperty("covered_shell_" + camera, std::to_string(a.covered));
    RecordProperty("covered_solid_" + camera, std::to_string(b.covered));
    RecordProperty("spilled_shell_" + camera, std::to_string(a.spilled));
    RecordProperty("spilled_solid_" + camera, std::to_string(b.spilled));
    // Measured: camera 1 covered 0.773 -> 1.000, spilled 0.200 -> 0.296;
    // camera 2 0.757 -> 1.000, 0.115 -> 0.233. Three times the chord
    // spills 0.61 and 0.63: the bound catches an object made too deep.
    EXPECT_GT(b.covered, 0.95) << "camera " << camera;
    EXPECT_GT(b.covered, a.covered + 0.15) << "camera " << camera;
    EXPECT_LT(b.spilled, 0.35) << "camera " << camera;
  }
}

}  // namespace
}  // namespace pano4d
