#pragma once

// The COLMAP command lines `pano4d sfm` runs, in COLMAP 3.8's option names
// (ColmapRunner maps them onto the installed version's). In one place so
// that the version tests run exactly what sfm runs.

#include <filesystem>
#include <string>
#include <vector>

namespace pano4d {

struct FeatureExtractorSettings {
  std::filesystem::path database, images;
  std::string camera_model;
  bool single_camera = false;
  std::filesystem::path masks;       // empty: no masks
  std::filesystem::path image_list;  // empty: every image in `images`
  std::string camera_params;         // empty: COLMAP estimates them
};
std::vector<std::string> FeatureExtractorArgs(
    const FeatureExtractorSettings& s);

// exhaustive_matcher and sequential_matcher: SIFT matching on the CPU.
std::vector<std::string> MatcherArgs(const std::filesystem::path& database);

// COLMAP's mapper settings for casual video, where consecutive frames see
// little parallax and moving objects take features: the inlier counts an
// initial pair and a registered frame need are relaxed (COLMAP's defaults:
// 100, 30 and 0.25), the triangulation angles kept. On lady-running at
// --max-size 160 the defaults posed 15 of 65 frames, these 65 (docs/
// experiments/2026-12-03-casual-video-posing.md).
std::vector<std::string> RelaxedMapperArgs();
std::vector<std::string> MapperArgs(const std::filesystem::path& database,
                                    const std::filesystem::path& images,
                                    const std::filesystem::path& output);

// Points for given poses and intrinsics: nothing else is refined.
std::vector<std::string> PointTriangulatorArgs(
    const std::filesystem::path& database, const std::filesystem::path& images,
    const std::filesystem::path& input, const std::filesystem::path& output);

std::vector<std::string> ImageUndistorterArgs(
    const std::filesystem::path& images, const std::filesystem::path& input,
    const std::filesystem::path& output);

}  // namespace pano4d
