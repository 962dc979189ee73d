#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace pano4d {

// An image row of a COLMAP database (database.db, SQLite).
struct DatabaseImage {
  std::uint32_t image_id = 0;
  std::uint32_t camera_id = 0;
  std::string name;
  int keypoints = 0;  // rows of its keypoints table entry; 0 when none
};

// COLMAP's verdict on an image pair (TwoViewGeometry::ConfigurationType,
// the same numbers from 3.8 to 4.1).
enum class PairConfig {
  kUndefined = 0,
  kDegenerate = 1,
  kCalibrated = 2,
  kUncalibrated = 3,
  kPlanar = 4,
  kPanoramic = 5,
  kPlanarOrPanoramic = 6,
  kWatermark = 7,
  kMultiple = 8,
};

// A verified pair of the two_view_geometries table.
struct DatabasePair {
  std::uint32_t image_id1 = 0, image_id2 = 0;
  int inliers = 0;  // verified matches (the table's rows)
  int config = 0;   // PairConfig
  // The inlier matches as indices into the two images' keypoints; read
  // only when asked (ReadDatabasePairs' with_matches).
  std::vector<std::array<std::uint32_t, 2>> matches;
};

// The images table of a COLMAP database, opened read-only, by image id,
// with each image's keypoint count. feature_extractor numbers images in the
// order its threads finish, so the ids of a model for point_triangulator
// must come from here. Throws pano4d::Error naming the file when it is
// missing or not a COLMAP database.
std::vector<DatabaseImage> ReadDatabaseImages(
    const std::filesystem::path& database);

// The order in which sequential_matcher pairs the database's images: by
// name as byte strings, whatever the image ids (COLMAP 3.8 to 4.1 sort by
// Image::Name in GetOrderedImageIds; feature_extractor's ids follow the
// order its threads finish). Throws as ReadDatabaseImages.
std::vector<std::string> SequentialMatcherOrder(
    const std::filesystem::path& database);

// The two_view_geometries table in pair id order (empty before a matcher
// ran), with each pair's inlier matches when `with_matches`. Throws as
// ReadDatabaseImages, and for a matches blob whose size disagrees with its
// rows and columns.
std::vector<DatabasePair> ReadDatabasePairs(
    const std::filesystem::path& database, bool with_matches = false);

// Keypoint positions by image id (pixels, COLMAP's convention: the first
// pixel's centre at 0.5). Throws as ReadDatabaseImages, and for a blob
// whose size disagrees with its rows and columns.
std::map<std::uint32_t, std::vector<Eigen::Vector2d>> ReadDatabaseKeypoints(
    const std::filesystem::path& database);

}  // namespace pano4d
