#include "back/colmap_database.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "back/canned_colmap_model.h"

namespace rumi {
namespace {

namespace fs = std::filesystem;

class ColmapDatabaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rumi_colmap_database_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
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

}  // namespace
}  // namespace rumi
