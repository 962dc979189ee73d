#include "colmap_ext/sfm_diagnosis.h"

#include <sqlite3.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "colmap_ext/database.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {

FrameEvidence Posed() {
  FrameEvidence f;
  f.posed = true;
  f.keypoints = 2000;
  f.verified_pairs = 4;
  return f;
}

// An unposed frame with plenty of keypoints and matches, and
// `rotation_only` of its 4 verified pairs explained by a homography.
FrameEvidence Unposed(int rotation_only) {
  FrameEvidence f;
  f.keypoints = 2000;
  f.best_inliers = 300;
  f.verified_pairs = 4;
  f.rotation_only_pairs = rotation_only;
  return f;
}

TEST(SfmDiagnosisTest, TheCauseOfMostUnposedFramesWithItsCounts) {
  std::vector<FrameEvidence> frames(10, Posed());
  for (int i = 0; i < 3; ++i) {
    FrameEvidence f = Unposed(0);
    f.keypoints = kFewKeypoints - 1;
    frames.push_back(f);
  }
  for (int i = 0; i < 5; ++i) frames.push_back(Unposed(3));
  FrameEvidence lonely = Unposed(0);
  lonely.verified_pairs = 0;
  frames.push_back(lonely);
  FrameEvidence covered = Unposed(0);
  covered.moving_fraction = 0.7;
  frames.push_back(covered);

  const SfmDiagnosis d = DiagnoseSfm(frames);
  EXPECT_EQ(d.frames, 20);
  EXPECT_EQ(d.posed, 10);
  EXPECT_DOUBLE_EQ(d.PosedFraction(), 0.5);
  EXPECT_EQ(d.cause, UnposedCause::kLittleParallax);
  EXPECT_EQ(d.unposed.at(UnposedCause::kFewFeatures), 3);
  EXPECT_EQ(d.unposed.at(UnposedCause::kLittleParallax), 5);
  EXPECT_EQ(d.unposed.at(UnposedCause::kNoMatches), 1);
  EXPECT_EQ(d.unposed.at(UnposedCause::kMovingObjects), 1);
  EXPECT_EQ(d.unposed.count(UnposedCause::kNotConnected), 0u);
  EXPECT_NE(d.Cause().find("too little parallax: 5 of 10 unposed frames"),
            std::string::npos)
      << d.Cause();
  EXPECT_NE(d.Remedy().find("--stride"), std::string::npos);
  const nlohmann::json j = d.ToJson();
  EXPECT_EQ(j["cause"], "too little parallax");
  EXPECT_EQ(j["unposed"], 10);
  EXPECT_EQ(j["unposed_causes"]["too few features"], 3);
  EXPECT_DOUBLE_EQ(j["posed_fraction"].get<double>(), 0.5);
}

TEST(SfmDiagnosisTest, EachFrameTakesTheFirstCauseThatApplies) {
  // Few keypoints and moving objects both: the features come first.
  FrameEvidence f = Unposed(4);
  f.keypoints = 10;
  f.moving_fraction = 0.9;
  EXPECT_EQ(DiagnoseSfm({f}).cause, UnposedCause::kFewFeatures);
  f.keypoints = 5000;
  EXPECT_EQ(DiagnoseSfm({f}).cause, UnposedCause::kMovingObjects);
  f.moving_fraction = 0.1;
  EXPECT_EQ(DiagnoseSfm({f}).cause, UnposedCause::kLittleParallax);
  // Half the pairs rotation-only is not a majority.
  EXPECT_EQ(DiagnoseSfm({Unposed(2)}).cause, UnposedCause::kNotConnected);
  // A tie goes to the more basic cause.
  FrameEvidence few = Unposed(0);
  few.keypoints = 0;
  EXPECT_EQ(DiagnoseSfm({Unposed(4), few}).cause, UnposedCause::kFewFeatures);
}

TEST(SfmDiagnosisTest, EveryFramePosedHasNoCause) {
  const SfmDiagnosis d = DiagnoseSfm({Posed(), Posed()});
  EXPECT_TRUE(d.AllPosed());
  EXPECT_EQ(d.Cause(), "every frame posed");
  EXPECT_EQ(d.ToJson()["cause"], "");
  EXPECT_EQ(d.ToJson()["unposed"], 0);
}

// A database as COLMAP 3.8 writes it, with the columns pano4d reads.
void WriteDatabase(const std::filesystem::path& path) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  constexpr long long kPair = 2147483647LL;
  const std::string sql =
      std::string(
          "CREATE TABLE images (image_id INTEGER PRIMARY KEY, name TEXT "
          "UNIQUE, "
          "camera_id INTEGER);"
          "CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY, rows INTEGER, "
          "cols INTEGER, data BLOB);"
          "CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY, rows "
          "INTEGER, cols INTEGER, data BLOB, config INTEGER);"
          "INSERT INTO images VALUES (1, 'a.png', 1), (2, 'b.png', 1), "
          "(3, 'c.png', 1);"
          "INSERT INTO keypoints VALUES (1, 900, 6, NULL), (2, 40, 6, NULL);") +
      // a-b: 200 inliers, a homography; a-c: 50, calibrated; b-c: 10.
      "INSERT INTO two_view_geometries VALUES (" +
      std::to_string(1 * kPair + 2) + ", 200, 2, NULL, 6), (" +
      std::to_string(1 * kPair + 3) + ", 50, 2, NULL, 2), (" +
      std::to_string(2 * kPair + 3) + ", 10, 2, NULL, 2);";
  ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
}

TEST(SfmDiagnosisTest, EvidenceFromTheDatabaseTheModelAndTheMasks) {
  testing::TempDir dir;
  WriteDatabase(dir / "database.db");
  const std::vector<DatabasePair> pairs =
      ReadDatabasePairs(dir / "database.db");
  ASSERT_EQ(pairs.size(), 3u);
  EXPECT_EQ(pairs[2].image_id1, 2u);
  EXPECT_EQ(pairs[2].image_id2, 3u);

  const std::vector<FrameEvidence> frames =
      ReadFrameEvidence(dir / "database.db", {"a.png"}, {{"c.png", 0.25}});
  ASSERT_EQ(frames.size(), 3u);
  const FrameEvidence &a = frames[0], &b = frames[1], &c = frames[2];
  EXPECT_TRUE(a.posed);
  EXPECT_FALSE(b.posed);
  EXPECT_EQ(a.keypoints, 900);
  EXPECT_EQ(c.keypoints, 0);  // no keypoints row
  EXPECT_EQ(a.best_inliers, 200);
  EXPECT_EQ(a.verified_pairs, 2);
  EXPECT_EQ(a.rotation_only_pairs, 1);
  EXPECT_EQ(b.verified_pairs, 1);  // b-c has fewer than kMinPairInliers
  EXPECT_EQ(b.rotation_only_pairs, 1);
  EXPECT_EQ(c.best_inliers, 50);
  EXPECT_DOUBLE_EQ(c.moving_fraction, 0.25);
  EXPECT_DOUBLE_EQ(b.moving_fraction, 0.0);
}

}  // namespace
}  // namespace pano4d
