#include "colmap_ext/database.h"

#include <sqlite3.h>

#include <fstream>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

TEST(DatabaseTest, ReadsImageRowsInIdOrder) {
  testing::TempDir dir;
  const auto path = dir / "database.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  // The columns of COLMAP 3.8's images table that pano4d reads.
  ASSERT_EQ(sqlite3_exec(db,
                         "CREATE TABLE images (image_id INTEGER PRIMARY KEY, "
                         "name TEXT UNIQUE, camera_id INTEGER);"
                         "INSERT INTO images VALUES (2, 'b.png', 1);"
                         "INSERT INTO images VALUES (1, 'a.png', 1);"
                         "INSERT INTO images VALUES (3, 'c.png', 7);",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  const std::vector<DatabaseImage> images = ReadDatabaseImages(path);
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(images[0].name, "a.png");
  EXPECT_EQ(images[1].image_id, 2u);
  EXPECT_EQ(images[2].camera_id, 7u);
}

TEST(DatabaseTest, TheSequentialMatcherOrderIsByNameNotById) {
  testing::TempDir dir;
  const auto path = dir / "database.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  // Ids as feature_extractor's threads may give them; names not padded.
  ASSERT_EQ(sqlite3_exec(db,
                         "CREATE TABLE images (image_id INTEGER PRIMARY KEY, "
                         "name TEXT UNIQUE, camera_id INTEGER);"
                         "INSERT INTO images VALUES (1, 'f2.png', 1);"
                         "INSERT INTO images VALUES (2, 'f10.png', 1);"
                         "INSERT INTO images VALUES (3, 'f1.png', 1);",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_EQ(SequentialMatcherOrder(path),
            (std::vector<std::string>{"f1.png", "f10.png", "f2.png"}));
}

TEST(DatabaseTest, MissingOrForeignFilesAreErrorsNamingThem) {
  testing::TempDir dir;
  EXPECT_THROW(ReadDatabaseImages(dir / "none.db"), Error);
  std::ofstream(dir / "text.db") << "not a database at all";
  try {
    ReadDatabaseImages(dir / "text.db");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("text.db"), std::string::npos);
  }
}

}  // namespace
}  // namespace pano4d
