#include "back/colmap_database.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "back/testing/canned_colmap_model.h"
#include "common/testing/temp_dir.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class ColmapDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override { tmp_.Create(); }
  TempDir tmp_;
  fs::path dir_ = tmp_.path();
};

TEST_F(ColmapDatabaseTest, KeypointCountsByImageName) {
  const fs::path db = dir_ / "database.db";
  ASSERT_TRUE(WriteCannedColmapDatabase(db, {{"a.png", 21}, {"b.png", 806}, {"c.png", 0}}));
  std::unordered_map<std::string, int> counts;
  std::string why;
  ASSERT_TRUE(ReadColmapKeypointCounts(db.string(), &counts, &why)) << why;
  ASSERT_EQ(counts.size(), 3u);
  EXPECT_EQ(counts["a.png"], 21);
  EXPECT_EQ(counts["b.png"], 806);
  EXPECT_EQ(counts["c.png"], 0);
}

TEST_F(ColmapDatabaseTest, MissingOrForeignFilesAreErrorsNamingTheFile) {
  std::unordered_map<std::string, int> counts{{"stale", 1}};
  std::string why;
  const fs::path missing = dir_ / "none.db";
  EXPECT_FALSE(ReadColmapKeypointCounts(missing.string(), &counts, &why));
  EXPECT_NE(why.find(missing.string()), std::string::npos) << why;
  EXPECT_TRUE(counts.empty());
  EXPECT_FALSE(fs::exists(missing)) << "opened read-only: nothing is created";

  const fs::path text = dir_ / "text.db";
  std::ofstream(text) << "not a database\n";
  EXPECT_FALSE(ReadColmapKeypointCounts(text.string(), &counts, &why));
  EXPECT_NE(why.find(text.string()), std::string::npos) << why;

  // An SQLite file without COLMAP's tables.
  const fs::path other = dir_ / "other.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE t (x INTEGER);", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  EXPECT_FALSE(ReadColmapKeypointCounts(other.string(), &counts, &why));
  EXPECT_NE(why.find("not a COLMAP database"), std::string::npos) << why;
}

// Row counts of `table` in `db`, keyed by its first column.
std::map<int64_t, int> Rows(const fs::path& db, const std::string& table) {
  std::map<int64_t, int> rows;
  sqlite3* h = nullptr;
  EXPECT_EQ(sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(h, ("SELECT * FROM " + table).c_str(), -1, &stmt, nullptr), SQLITE_OK) << table;
  while (stmt && sqlite3_step(stmt) == SQLITE_ROW) rows[sqlite3_column_int64(stmt, 0)] = sqlite3_column_int(stmt, 1);
  sqlite3_finalize(stmt);
  sqlite3_close(h);
  return rows;
}

TEST_F(ColmapDatabaseTest, VerifiedPairsByImageName) {
  const fs::path db = dir_ / "database.db";
  // Pair inliers: the smaller keypoint count of the two.
  ASSERT_TRUE(WriteCannedColmapDatabase(db, {{"a.png", 500}, {"b.png", 10}, {"c.png", 400}}));
  std::vector<std::pair<std::string, std::string>> pairs{{"stale", "stale"}};
  std::string why;
  ASSERT_TRUE(ReadColmapVerifiedPairs(db.string(), 15, &pairs, &why)) << why;
  EXPECT_EQ(pairs, (std::vector<std::pair<std::string, std::string>>{{"a.png", "c.png"}}));
  ASSERT_TRUE(ReadColmapVerifiedPairs(db.string(), 10, &pairs, &why)) << why;
  EXPECT_EQ(pairs.size(), 3u);
  EXPECT_FALSE(ReadColmapVerifiedPairs((dir_ / "none.db").string(), 15, &pairs, &why));
  EXPECT_NE(why.find("none.db"), std::string::npos) << why;
  EXPECT_TRUE(pairs.empty());
}

TEST_F(ColmapDatabaseTest, ACopyForgetsTheNamedImagesAndTheirPairs) {
  const fs::path from = dir_ / "database.db", to = dir_ / "database_retry.db";
  ASSERT_TRUE(WriteCannedColmapDatabase(from, {{"a.png", 500}, {"b.png", 20}, {"c.png", 400}, {"d.png", 30}}));
  std::ofstream(to) << "a stale copy\n";
  int forgotten = -1;
  std::string why;
  ASSERT_TRUE(CopyColmapDatabase(from.string(), to.string(), {"b.png", "d.png", "no_such.png"}, &forgotten, &why))
      << why;
  EXPECT_EQ(forgotten, 2);
  const int64_t k = 2147483647;
  // Images 1 and 3 keep their features and the one pair between them.
  EXPECT_EQ(Rows(to, "keypoints"), (std::map<int64_t, int>{{1, 500}, {3, 400}}));
  EXPECT_EQ(Rows(to, "descriptors"), (std::map<int64_t, int>{{1, 500}, {3, 400}}));
  EXPECT_EQ(Rows(to, "matches"), (std::map<int64_t, int>{{k * 1 + 3, 400}}));
  EXPECT_EQ(Rows(to, "two_view_geometries"), (std::map<int64_t, int>{{k * 1 + 3, 400}}));
  EXPECT_EQ(Rows(to, "images").size(), 4u) << "the images stay: COLMAP extracts them again";
  // The original is untouched.
  EXPECT_EQ(Rows(from, "keypoints").size(), 4u);
  EXPECT_EQ(Rows(from, "matches").size(), 6u);
  // Nothing to forget: a plain copy.
  ASSERT_TRUE(CopyColmapDatabase(from.string(), to.string(), {}, &forgotten, &why)) << why;
  EXPECT_EQ(forgotten, 0);
  EXPECT_EQ(Rows(to, "matches").size(), 6u);
}

TEST_F(ColmapDatabaseTest, AFailedCopyNamesTheFileAndLeavesNoCopy) {
  const fs::path to = dir_ / "copy.db";
  std::string why;
  const fs::path missing = dir_ / "none.db";
  EXPECT_FALSE(CopyColmapDatabase(missing.string(), to.string(), {"a.png"}, nullptr, &why));
  EXPECT_NE(why.find(missing.string()), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(missing));
  EXPECT_FALSE(fs::exists(to));

  const fs::path text = dir_ / "text.db";
  std::ofstream(text) << "not a database\n";
  EXPECT_FALSE(CopyColmapDatabase(text.string(), to.string(), {"a.png"}, nullptr, &why));
  EXPECT_NE(why.find(text.string()), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(to));

  // SQLite without COLMAP's tables.
  const fs::path other = dir_ / "other.db";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE images (image_id INTEGER, name TEXT);", nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  EXPECT_FALSE(CopyColmapDatabase(other.string(), to.string(), {"a.png"}, nullptr, &why));
  EXPECT_NE(why.find("not a COLMAP database"), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(to));

  // A copy that cannot be written.
  ASSERT_TRUE(WriteCannedColmapDatabase(other, {{"a.png", 5}}));
  const fs::path nowhere = dir_ / "no_dir" / "copy.db";
  EXPECT_FALSE(CopyColmapDatabase(other.string(), nowhere.string(), {}, nullptr, &why));
  EXPECT_NE(why.find(nowhere.string()), std::string::npos) << why;
}

}  // namespace
}  // namespace rumi
