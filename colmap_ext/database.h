#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace pano4d {

// An image row of a COLMAP database (database.db, SQLite).
struct DatabaseImage {
  std::uint32_t image_id = 0;
  std::uint32_t camera_id = 0;
  std::string name;
};

// The images table of a COLMAP database, opened read-only, by image id.
// feature_extractor numbers images in the order its threads finish, so the
// ids of a model for point_triangulator must come from here. Throws
// pano4d::Error naming the file when it is missing or not a COLMAP
// database.
std::vector<DatabaseImage> ReadDatabaseImages(
    const std::filesystem::path& database);

}  // namespace pano4d
