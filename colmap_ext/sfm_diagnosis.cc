#include "colmap_ext/sfm_diagnosis.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "colmap_ext/database.h"
#include "src/core/strings.h"

namespace pano4d {
namespace {

UnposedCause CauseOf(const FrameEvidence& f) {
  if (f.keypoints < kFewKeypoints) return UnposedCause::kFewFeatures;
  if (f.moving_fraction > kDominantMovingFraction)
    return UnposedCause::kMovingObjects;
  if (f.verified_pairs == 0) return UnposedCause::kNoMatches;
  if (2 * f.rotation_only_pairs > f.verified_pairs)
    return UnposedCause::kLittleParallax;
  return UnposedCause::kNotConnected;
}

std::string Explanation(UnposedCause cause) {
  switch (cause) {
    case UnposedCause::kFewFeatures:
      return StringPrintf(
          "have fewer than %d SIFT keypoints (blur, no texture or "
          "over-exposure)",
          kFewKeypoints);
    case UnposedCause::kMovingObjects:
      return StringPrintf(
          "are more than %.0f%% covered by moving objects, which feature "
          "extraction leaves out",
          100 * kDominantMovingFraction);
    case UnposedCause::kNoMatches:
      return StringPrintf(
          "share fewer than %d verified matches with every other frame",
          kMinPairInliers);
    case UnposedCause::kLittleParallax:
      return "match their neighbours only by a homography (the camera turns "
             "or barely moves: nothing to triangulate)";
    case UnposedCause::kNotConnected:
      return "match other frames, yet the mapper did not register them (a "
             "separate model, or a pose that failed bundle adjustment)";
  }
  return "";
}

}  // namespace

const char* UnposedCauseName(UnposedCause cause) {
  switch (cause) {
    case UnposedCause::kFewFeatures:
      return "too few features";
    case UnposedCause::kMovingObjects:
      return "moving objects dominate";
    case UnposedCause::kNoMatches:
      return "frames do not overlap";
    case UnposedCause::kLittleParallax:
      return "too little parallax";
    case UnposedCause::kNotConnected:
      return "frames not connected";
  }
  return "unknown";
}

std::string SfmDiagnosis::Cause() const {
  if (AllPosed()) return "every frame posed";
  const auto found = unposed.find(cause);
  const int n = found == unposed.end() ? 0 : found->second;
  return StringPrintf("%s: %d of %d unposed frames %s", UnposedCauseName(cause),
                      n, frames - posed, Explanation(cause).c_str());
}

std::string SfmDiagnosis::Remedy() const {
  switch (cause) {
    case UnposedCause::kFewFeatures:
      return "a larger --max-size (more pixels for SIFT), a sharper or "
             "better-lit video, or frames with more texture";
    case UnposedCause::kMovingObjects:
      return "a video where more of the background shows, or poses from "
             "elsewhere (`pano4d run --colmap WS`)";
    case UnposedCause::kNoMatches:
      return "a lower --stride (consecutive frames overlap more), "
             "`pano4d sfm --matcher exhaustive`, or a slower camera";
    case UnposedCause::kLittleParallax:
      return "a video whose camera moves sideways rather than only turning, "
             "a larger --stride for wider baselines, or poses from elsewhere "
             "(`pano4d run --colmap WS`)";
    case UnposedCause::kNotConnected:
      return "`pano4d sfm --matcher exhaustive` (more pairs to join the "
             "models), or a lower --stride";
  }
  return "";
}

nlohmann::json SfmDiagnosis::ToJson() const {
  nlohmann::json causes = nlohmann::json::object();
  for (const auto& [c, n] : unposed) causes[UnposedCauseName(c)] = n;
  return {{"frames", frames},
          {"posed", posed},
          {"posed_fraction", PosedFraction()},
          {"unposed", frames - posed},
          {"unposed_causes", causes},
          {"cause", AllPosed() ? "" : UnposedCauseName(cause)},
          {"explanation", AllPosed() ? "" : Cause()},
          {"remedy", AllPosed() ? "" : Remedy()}};
}

SfmDiagnosis DiagnoseSfm(const std::vector<FrameEvidence>& frames) {
  SfmDiagnosis d;
  d.frames = static_cast<int>(frames.size());
  for (const FrameEvidence& f : frames) {
    if (f.posed) {
      ++d.posed;
      continue;
    }
    ++d.unposed[CauseOf(f)];
  }
  // The most common cause; ties go to the earlier (more basic) one.
  int most = 0;
  for (const auto& [c, n] : d.unposed) {
    if (n > most) {
      most = n;
      d.cause = c;
    }
  }
  return d;
}

std::vector<FrameEvidence> ReadFrameEvidence(
    const std::filesystem::path& database, const std::set<std::string>& posed,
    const std::map<std::string, double>& moving_fraction) {
  const std::vector<DatabaseImage> images = ReadDatabaseImages(database);
  std::map<std::uint32_t, std::size_t> index;
  std::vector<FrameEvidence> frames;
  for (const DatabaseImage& image : images) {
    index[image.image_id] = frames.size();
    FrameEvidence f;
    f.name = image.name;
    f.posed = posed.count(image.name) > 0;
    f.keypoints = image.keypoints;
    const auto moving = moving_fraction.find(image.name);
    if (moving != moving_fraction.end()) f.moving_fraction = moving->second;
    frames.push_back(f);
  }
  for (const DatabasePair& pair : ReadDatabasePairs(database)) {
    const bool rotation_only =
        pair.config == static_cast<int>(PairConfig::kPanoramic) ||
        pair.config == static_cast<int>(PairConfig::kPlanarOrPanoramic);
    for (const std::uint32_t id : {pair.image_id1, pair.image_id2}) {
      const auto found = index.find(id);
      if (found == index.end()) continue;
      FrameEvidence& f = frames[found->second];
      f.best_inliers = std::max(f.best_inliers, pair.inliers);
      if (pair.inliers < kMinPairInliers) continue;
      ++f.verified_pairs;
      if (rotation_only) ++f.rotation_only_pairs;
    }
  }
  return frames;
}

}  // namespace pano4d
