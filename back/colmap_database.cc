#include "back/colmap_database.h"

#include <sqlite3.h>

#include <cstdio>
#include <functional>

namespace rumi {

namespace {

// Runs `sql` on the database opened read-only and hands each row to `row`.
bool ReadRows(const std::string& database_path, const char* sql, const std::string& tables,
              const std::function<void(sqlite3_stmt*)>& row, std::string* why) {
  sqlite3* db = nullptr;
  auto fail = [&](const std::string& what) {
    if (why) *why = database_path + ": " + what + (db ? std::string(": ") + sqlite3_errmsg(db) : "");
    if (db) sqlite3_close(db);
    return false;
  };
  // Read-only and without creating: a missing file is an error, not an empty database.
  if (sqlite3_open_v2(database_path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    return fail("cannot open the COLMAP database");
  sqlite3_busy_timeout(db, 5000);
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK)
    return fail("not a COLMAP database (no " + tables + " tables)");
  int rc;
  while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) row(stmt);
  sqlite3_finalize(stmt);
  if (rc != SQLITE_DONE) return fail("reading the " + tables + " failed");
  sqlite3_close(db);
  return true;
}

std::string Text(sqlite3_stmt* stmt, int column) {
  const unsigned char* t = sqlite3_column_text(stmt, column);
  return t ? reinterpret_cast<const char*>(t) : "";
}

}  // namespace

bool ReadColmapKeypointCounts(const std::string& database_path, std::unordered_map<std::string, int>* counts,
                              std::string* why) {
  counts->clear();
  return ReadRows(
      database_path,
      "SELECT images.name, keypoints.rows FROM images JOIN keypoints ON images.image_id = keypoints.image_id",
      "images/keypoints", [&](sqlite3_stmt* s) { (*counts)[Text(s, 0)] = sqlite3_column_int(s, 1); }, why);
}

bool ReadColmapVerifiedPairs(const std::string& database_path, int min_inliers,
                             std::vector<std::pair<std::string, std::string>>* pairs, std::string* why) {
  pairs->clear();
  // pair_id = 2147483647 * image_id1 + image_id2 with image_id1 < image_id2 (COLMAP's database.cc).
  const std::string sql =
      "SELECT a.name, b.name FROM two_view_geometries g JOIN images a ON a.image_id = g.pair_id / 2147483647 "
      "JOIN images b ON b.image_id = g.pair_id % 2147483647 WHERE g.rows >= " + std::to_string(min_inliers);
  return ReadRows(
      database_path, sql.c_str(), "images/two_view_geometries",
      [&](sqlite3_stmt* s) { pairs->emplace_back(Text(s, 0), Text(s, 1)); }, why);
}

bool CopyColmapDatabase(const std::string& from, const std::string& to, const std::vector<std::string>& forget,
                        int* forgotten, std::string* why) {
  if (forgotten) *forgotten = 0;
  sqlite3 *src = nullptr, *dst = nullptr;
  auto fail = [&](const std::string& file, sqlite3* db, const std::string& what) {
    if (why) *why = file + ": " + what + (db ? std::string(": ") + sqlite3_errmsg(db) : "");
    if (src) sqlite3_close(src);
    if (dst) sqlite3_close(dst);
    std::remove(to.c_str());
    return false;
  };
  if (sqlite3_open_v2(from.c_str(), &src, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK)
    return fail(from, src, "cannot open the COLMAP database");
  std::remove(to.c_str());
  if (sqlite3_open(to.c_str(), &dst) != SQLITE_OK) return fail(to, dst, "cannot create the database copy");
  sqlite3_busy_timeout(src, 5000);
  // The backup API copies what a reader sees, write-ahead log included.
  sqlite3_backup* backup = sqlite3_backup_init(dst, "main", src, "main");
  if (!backup) return fail(to, dst, "cannot copy the COLMAP database");
  const int step = sqlite3_backup_step(backup, -1);
  sqlite3_backup_finish(backup);
  if (step != SQLITE_DONE) return fail(from, src, "copying the COLMAP database failed");
  sqlite3_close(src);
  src = nullptr;

  // pair_id = 2147483647 * image_id1 + image_id2 with image_id1 < image_id2 (COLMAP's database.cc).
  const char* schema =
      "BEGIN; CREATE TEMP TABLE forget (image_id INTEGER PRIMARY KEY);";
  const char* drop =
      "DELETE FROM keypoints WHERE image_id IN forget;"
      "DELETE FROM descriptors WHERE image_id IN forget;"
      "DELETE FROM matches WHERE pair_id / 2147483647 IN forget OR pair_id % 2147483647 IN forget;"
      "DELETE FROM two_view_geometries WHERE pair_id / 2147483647 IN forget OR pair_id % 2147483647 IN forget;"
      "COMMIT;";
  if (sqlite3_exec(dst, schema, nullptr, nullptr, nullptr) != SQLITE_OK)
    return fail(to, dst, "cannot prepare the copy");
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(dst, "INSERT OR IGNORE INTO forget SELECT image_id FROM images WHERE name = ?", -1, &stmt,
                         nullptr) != SQLITE_OK)
    return fail(from, dst, "not a COLMAP database (no images table)");
  for (const std::string& name : forget) {
    sqlite3_bind_text(stmt, 1, name.c_str(), -1, SQLITE_TRANSIENT);
    if (sqlite3_step(stmt) != SQLITE_DONE) {
      sqlite3_finalize(stmt);
      return fail(to, dst, "cannot list the images to extract again");
    }
    if (forgotten) *forgotten += sqlite3_changes(dst);
    sqlite3_reset(stmt);
  }
  sqlite3_finalize(stmt);
  if (sqlite3_exec(dst, drop, nullptr, nullptr, nullptr) != SQLITE_OK)
    return fail(from, dst, "not a COLMAP database (no keypoints, descriptors, matches or two_view_geometries table)");
  if (sqlite3_close(dst) != SQLITE_OK) return fail(to, dst, "cannot close the database copy");
  return true;
}

}  // namespace rumi
