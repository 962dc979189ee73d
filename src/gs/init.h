#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/geometry/point_cloud.h"
#include "src/geometry/tracks.h"
#include "src/gs/scene.h"
#include "src/gs/training_view.h"

namespace pano4d {

// Gaussians from the training views' depth (DESIGN.md "init"): static
// pixels of every view unprojected, denoised (PCL statistical outlier
// removal) and thinned (PCL voxel grid); dynamic pixels of the canonical
// frame the same way; initial scales from the mean distance to the 3
// nearest neighbours (FLANN). Motion bases from 2D flow tracks of the
// canonical frame's dynamic pixels, lifted with depth: k-means on their 3D
// displacements, then one Procrustes fit (Eigen::umeyama) per cluster and
// frame. A scene without dynamic pixels gets no dynamic Gaussians and no
// bases.
// Each moving pixel seeds this many Gaussians behind it, all of them
// before max_dynamic thins them: more layers than this only cost memory
// (a million grew it by 800 MB/s), the object's volume does not need them.
inline constexpr int kMaxDynamicLayers = 16;

struct InitOptions {
  int pixel_stride = 2;  // static pixels: every stride-th in x and y
  // Voxel edge in pixels at the median depth (world size = median depth x
  // voxel_pixels / median focal length).
  double voxel_pixels = 2.0;
  PointCloudFilterOptions filter;    // its voxel_size is set from the above
  std::int64_t max_static = 150000;  // CPU time grows with the count
  std::int64_t max_dynamic = 50000;
  // K; 0 treats every pixel as static. 20 rather than 10: each basis is
  // one rigid motion, and a bending object needs more of them
  // (docs/experiments/2026-11-22-motion-bases-10-vs-20.md).
  int num_bases = 20;
  // Moving objects are solid, but the canonical frame shows one side of
  // them: its moving pixels start Gaussians on that surface only, a shell
  // that a camera 75 degrees aside sees half as wide. Each moving pixel
  // also seeds `dynamic_layers` Gaussians behind it, evenly out to
  // dynamic_thickness x the depth that a round cross-section of the mask's
  // local width has there (ChordPixels in init.cc). 0 leaves the shell.
  // Measured in docs/experiments/2026-11-24-moving-objects-volume.md.
  double dynamic_thickness = 1.0;
  int dynamic_layers = 2;  // at most kMaxDynamicLayers
  int track_stride = 3;    // seeds: every stride-th dynamic pixel
  TrackOptions tracks;
  // Fewer valid tracks than this in a cluster at a time: that time's pose
  // is taken from the nearest time that has enough.
  int min_tracks_per_fit = 6;
  double initial_opacity = 0.1;
  int sh_degree = 0;
  void Check() const;  // throws pano4d::Error naming the field
  nlohmann::json ToJson() const;
};

struct InitReport {
  std::int64_t static_points_raw = 0, static_points = 0;
  std::int64_t dynamic_points_raw = 0, dynamic_points = 0;
  std::int64_t tracks = 0;
  double track_coverage = 0.0;  // valid (track, time) pairs / all
  // What the tracks followed: "DIS" flow (computed), "priors" (the views'
  // learned flow) or "tracker" (given tracks).
  std::string track_flow = "DIS";
  int num_bases = 0;
  int canonical_time = 0;
  double voxel_size = 0.0;
  double seconds = 0.0;
  std::string Brief() const;  // one line for logs
  nlohmann::json ToJson() const;
};

// Gaussians at the cloud's points: colour as SH degree 0, isotropic scale
// the mean distance to the 3 nearest neighbours clamped to [0.25, 8] voxels,
// identity rotation, opacity options.initial_opacity. Also used for the
// Gaussians the expansion adds in unseen regions.
GaussianModel GaussiansFromCloud(const PointCloud& cloud, double voxel,
                                 const InitOptions& options);

// `views` as the trainer uses them (depth required on the views that
// contribute; views without depth are skipped with a warning). `seed`
// draws the motion clusters' k-means start.
// `tracks`, when given (a tracker's, learned priors), are followed instead
// of flow: those seen at the canonical time on a moving pixel with depth,
// when there are at least kMinGivenTracks of them.
inline constexpr int kMinGivenTracks = 30;
GaussianScene InitializeScene(const std::vector<TrainingView>& views,
                              int num_times, const InitOptions& options,
                              std::uint64_t seed, InitReport* report = nullptr,
                              const Tracks2D* tracks = nullptr);

}  // namespace pano4d
