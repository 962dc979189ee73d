#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "src/gs/training_view.h"

namespace pano4d {

// Training pairs for a video prior (DESIGN.md, "Panoramic Trajectories
// Training"): for a clip of the source video, a random tangent direction d
// and a fixed elevation; frame i's camera orbits the panorama centre by
// elevation x i / (frames - 1) about n x d (uniform samples along the
// direction). Each source frame is warped to its target camera with its
// depth and back (double reprojection): what survives the round trip is
// V_cov, the rest is the mask a prior must fill; V_src is the source frame.
struct PairOptions {
  int clips = 1;
  int frames = 49;  // per clip (TrajectoryCrafter's); fewer if the video is
  double elevation_degrees = 30.0;
  std::uint64_t seed = 0;
  void Check() const;  // throws pano4d::Error naming the field
};

struct PairsReport {
  int clips = 0;
  int frames_per_clip = 0;
  double mask_fraction = 0.0;  // mean over frames of |mask| / pixels
  nlohmann::json ToJson() const;
};

// Writes out/clip_<k>/{cov,mask,src}/<i>.png and out/clip_<k>/meta.json
// (direction angle, elevation, source frames, target cameras). `views` are
// the training frames (any order: taken in time order), with depth. Throws
// pano4d::Error when a view has no depth (the pairs need geometry) or there are
// no views.
PairsReport MakeTrainingPairs(const std::vector<TrainingView>& views,
                              const PairOptions& options,
                              const std::filesystem::path& out);

}  // namespace pano4d
