#include "colmap_ext/database.h"

#include <algorithm>

#include <sqlite3.h>

#include <functional>
#include <map>
#include <memory>

#include "src/core/error.h"

namespace pano4d {
namespace {

// COLMAP packs an image pair into one id: id1 * kMaxImages + id2, id1 < id2
// (Database::ImagePairToPairId).
constexpr std::int64_t kMaxImages = 2147483647;

// Runs `sql` on the database opened read-only and calls `row` per result
// row. Throws pano4d::Error naming the file and `what` on failure.
void Query(const std::filesystem::path& database, const char* sql,
           const std::string& what,
           const std::function<void(sqlite3_stmt*)>& row) {
  if (!std::filesystem::is_regular_file(database))
    throw Error::In(database.string(), "no such COLMAP database");
  sqlite3* raw = nullptr;
  const int open =
      sqlite3_open_v2(database.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  const std::unique_ptr<sqlite3, decltype(&sqlite3_close)> db(raw,
                                                              &sqlite3_close);
  if (open != SQLITE_OK) {
    throw Error::In(database.string(),
                    std::string("cannot open: ") + sqlite3_errstr(open));
  }
  sqlite3_stmt* raw_statement = nullptr;
  if (sqlite3_prepare_v2(db.get(), sql, -1, &raw_statement, nullptr) !=
      SQLITE_OK) {
    throw Error::In(database.string(), "not a COLMAP database (reading " +
                                           what +
                                           "): " + sqlite3_errmsg(db.get()));
  }
  const std::unique_ptr<sqlite3_stmt, decltype(&sqlite3_finalize)> statement(
      raw_statement, &sqlite3_finalize);
  int step;
  while ((step = sqlite3_step(statement.get())) == SQLITE_ROW)
    row(statement.get());
  if (step != SQLITE_DONE) {
    throw Error::In(database.string(),
                    "reading " + what + ": " + sqlite3_errmsg(db.get()));
  }
}

}  // namespace

std::vector<std::string> SequentialMatcherOrder(
    const std::filesystem::path& database) {
  std::vector<std::string> names;
  for (const DatabaseImage& image : ReadDatabaseImages(database))
    names.push_back(image.name);
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<DatabaseImage> ReadDatabaseImages(
    const std::filesystem::path& database) {
  std::vector<DatabaseImage> images;
  Query(database,
        "SELECT image_id, camera_id, name FROM images ORDER BY image_id",
        "images", [&](sqlite3_stmt* s) {
          const auto* name =
              reinterpret_cast<const char*>(sqlite3_column_text(s, 2));
          images.push_back(
              {static_cast<std::uint32_t>(sqlite3_column_int64(s, 0)),
               static_cast<std::uint32_t>(sqlite3_column_int64(s, 1)),
               name ? name : ""});
        });
  std::map<std::uint32_t, int> keypoints;
  // feature_extractor creates the table; a database made by hand may not.
  bool has_keypoints = false;
  Query(database,
        "SELECT name FROM sqlite_master WHERE type='table' AND "
        "name='keypoints'",
        "tables", [&](sqlite3_stmt*) { has_keypoints = true; });
  if (has_keypoints) {
    Query(database, "SELECT image_id, rows FROM keypoints", "keypoints",
          [&](sqlite3_stmt* s) {
            keypoints[static_cast<std::uint32_t>(sqlite3_column_int64(s, 0))] =
                sqlite3_column_int(s, 1);
          });
  }
  for (DatabaseImage& image : images) {
    const auto found = keypoints.find(image.image_id);
    if (found != keypoints.end()) image.keypoints = found->second;
  }
  return images;
}

namespace {

// A blob of rows x cols values of T, checked against its size.
template <typename T>
const T* Blob(sqlite3_stmt* s, int column, int rows, int cols,
              const std::filesystem::path& database, const std::string& what) {
  const int bytes = sqlite3_column_bytes(s, column);
  if (rows < 0 || cols < 0 ||
      static_cast<std::int64_t>(bytes) !=
          static_cast<std::int64_t>(rows) * cols *
              static_cast<std::int64_t>(sizeof(T))) {
    throw Error(database.string(), what, std::to_string(bytes) + " bytes",
                "expected rows " + std::to_string(rows) + " x cols " +
                    std::to_string(cols) + " x " + std::to_string(sizeof(T)));
  }
  return static_cast<const T*>(sqlite3_column_blob(s, column));
}

}  // namespace

std::map<std::uint32_t, std::vector<Eigen::Vector2d>> ReadDatabaseKeypoints(
    const std::filesystem::path& database) {
  std::map<std::uint32_t, std::vector<Eigen::Vector2d>> keypoints;
  Query(database, "SELECT image_id, rows, cols, data FROM keypoints",
        "keypoints", [&](sqlite3_stmt* s) {
          const int rows = sqlite3_column_int(s, 1);
          const int cols = sqlite3_column_int(s, 2);
          const float* data =
              Blob<float>(s, 3, rows, cols, database, "keypoints");
          if (rows > 0 && cols < 2) {
            throw Error(database.string(), "keypoints cols",
                        std::to_string(cols), "expected at least x and y");
          }
          auto& points =
              keypoints[static_cast<std::uint32_t>(sqlite3_column_int64(s, 0))];
          for (int r = 0; r < rows; ++r)
            points.emplace_back(data[r * cols], data[r * cols + 1]);
        });
  return keypoints;
}

std::vector<DatabasePair> ReadDatabasePairs(
    const std::filesystem::path& database, bool with_matches) {
  std::vector<DatabasePair> pairs;
  Query(database,
        with_matches ? "SELECT pair_id, rows, config, cols, data FROM "
                       "two_view_geometries ORDER BY pair_id"
                     : "SELECT pair_id, rows, config FROM two_view_geometries "
                       "ORDER BY pair_id",
        "two_view_geometries", [&](sqlite3_stmt* s) {
          const std::int64_t pair_id = sqlite3_column_int64(s, 0);
          DatabasePair p;
          p.image_id2 = static_cast<std::uint32_t>(pair_id % kMaxImages);
          p.image_id1 =
              static_cast<std::uint32_t>((pair_id - p.image_id2) / kMaxImages);
          p.inliers = sqlite3_column_int(s, 1);
          p.config = sqlite3_column_int(s, 2);
          if (with_matches && p.inliers > 0) {
            const int cols = sqlite3_column_int(s, 3);
            if (cols != 2) {
              throw Error(database.string(), "two_view_geometries cols",
                          std::to_string(cols), "expected 2");
            }
            const std::uint32_t* data = Blob<std::uint32_t>(
                s, 4, p.inliers, cols, database, "two_view_geometries");
            for (int r = 0; r < p.inliers; ++r)
              p.matches.push_back({data[2 * r], data[2 * r + 1]});
          }
          pairs.push_back(std::move(p));
        });
  return pairs;
}

}  // namespace pano4d
