#pragma once

// Why structure from motion left frames without a pose, from what COLMAP's
// database says of each frame (keypoints, verified pairs and their
// two-view configuration) and what the dynamic masks cover. `pano4d sfm`
// reports it; `pano4d run` stops with it when too few frames are posed.

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace pano4d {

// What is known of one frame after the mapper.
struct FrameEvidence {
  std::string name;
  bool posed = false;
  int keypoints = 0;
  int best_inliers = 0;    // verified matches with its best partner
  int verified_pairs = 0;  // pairs with at least kMinPairInliers
  // Of those, pairs that a homography explains (COLMAP's PANORAMIC or
  // PLANAR_OR_PANORAMIC): a camera that turned without moving.
  int rotation_only_pairs = 0;
  double moving_fraction = 0.0;  // of its pixels, by the dynamic mask
};

// COLMAP verifies a pair with at least this many inliers
// (TwoViewGeometryOptions::min_num_inliers' default).
constexpr int kMinPairInliers = 15;
// Below this many SIFT keypoints a frame seldom keeps kMinPairInliers
// verified matches with any neighbour (blur, no texture, over-exposure).
constexpr int kFewKeypoints = 100;
// Moving objects masked out of more than this share of a frame leave too
// little background for a pose.
constexpr double kDominantMovingFraction = 0.5;

// Why an unposed frame was left out, the first that applies in this order.
enum class UnposedCause {
  kFewFeatures,     // < kFewKeypoints keypoints
  kMovingObjects,   // the dynamic mask covers > kDominantMovingFraction
  kNoMatches,       // no partner with kMinPairInliers verified matches
  kLittleParallax,  // most verified pairs are rotation-only
  kNotConnected,    // matched, yet the mapper did not register it
};
const char* UnposedCauseName(UnposedCause cause);  // "too few features", ...

struct SfmDiagnosis {
  int frames = 0, posed = 0;
  std::map<UnposedCause, int> unposed;  // frames per cause
  // The cause of most unposed frames (meaningless when none is unposed).
  UnposedCause cause = UnposedCause::kNotConnected;

  double PosedFraction() const { return frames > 0 ? 1.0 * posed / frames : 0; }
  bool AllPosed() const { return posed == frames; }
  // "too little parallax: 101 of 133 unposed frames match their neighbours
  // only by a homography (the camera turns or barely moves)".
  std::string Cause() const;
  std::string Remedy() const;  // what to try, with pano4d's options
  // sfm.json's keys: posed_fraction, unposed, unposed_causes, cause, remedy.
  nlohmann::json ToJson() const;
};

SfmDiagnosis DiagnoseSfm(const std::vector<FrameEvidence>& frames);

// Each image of the database with what the database says of it; `posed`
// holds the names of the images the model registered, `moving_fraction`
// each frame's masked share by name (missing: 0). Throws pano4d::Error
// naming the database when it cannot be read.
std::vector<FrameEvidence> ReadFrameEvidence(
    const std::filesystem::path& database, const std::set<std::string>& posed,
    const std::map<std::string, double>& moving_fraction);

}  // namespace pano4d
