#include "back/colmap_database.h"

#include <sqlite3.h>

namespace rumi {

bool ReadColmapKeypointCounts(const std::string& database_path, std::unordered_map<std::string, int>* counts,
                              std::string* why) {
  counts->clear();
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
  const char* sql =
      "SELECT images.name, keypoints.rows FROM images JOIN keypoints ON images.image_id = keypoints.image_id";
  if (sqlite3_prepare_v2(db, sql, -1, &stmt, nullptr) != SQLITE_OK)
    return fail("not a COLMAP database (no images/keypoints tables)");
  int rc;
  while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) {
    const unsigned char* name = sqlite3_column_text(stmt, 0);
    if (name) (*counts)[reinterpret_cast<const char*>(name)] = sqlite3_column_int(stmt, 1);
  }
  sqlite3_finalize(stmt);
  if (rc != SQLITE_DONE) return fail("reading the keypoints failed");
  sqlite3_close(db);
  return true;
}

}  // namespace rumi
