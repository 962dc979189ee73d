#include "colmap_ext/database.h"

#include <sqlite3.h>

#include <memory>

#include "src/core/error.h"

namespace pano4d {

std::vector<DatabaseImage> ReadDatabaseImages(
    const std::filesystem::path& database) {
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
  if (sqlite3_prepare_v2(db.get(),
                         "SELECT image_id, camera_id, name FROM images "
                         "ORDER BY image_id",
                         -1, &raw_statement, nullptr) != SQLITE_OK) {
    throw Error::In(database.string(), std::string("not a COLMAP database: ") +
                                           sqlite3_errmsg(db.get()));
  }
  const std::unique_ptr<sqlite3_stmt, decltype(&sqlite3_finalize)> statement(
      raw_statement, &sqlite3_finalize);
  std::vector<DatabaseImage> images;
  int step;
  while ((step = sqlite3_step(statement.get())) == SQLITE_ROW) {
    const auto* name =
        reinterpret_cast<const char*>(sqlite3_column_text(statement.get(), 2));
    images.push_back(
        {static_cast<std::uint32_t>(sqlite3_column_int64(statement.get(), 0)),
         static_cast<std::uint32_t>(sqlite3_column_int64(statement.get(), 1)),
         name ? name : ""});
  }
  if (step != SQLITE_DONE) {
    throw Error::In(database.string(),
                    std::string("reading images: ") + sqlite3_errmsg(db.get()));
  }
  return images;
}

}  // namespace pano4d
