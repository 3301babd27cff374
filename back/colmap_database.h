#pragma once
// Reads what the back needs from a COLMAP database (SQLite, the schema of
// COLMAP's database.cc): how many SIFT keypoints each image got. The back
// uses it to tell texture-poor frames (few features at the SIFT threshold:
// the retry at a lower one registers them) from frames the selected pairs
// left unlinked (the fill registers them). It also copies a database for
// the retry, keeping what the retry can reuse.
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace rumi {

// Image name -> keypoint count, for every image with a keypoints row.
// Opens the database read-only. False with `why` (naming the file) when it
// cannot be opened or has no images/keypoints tables.
bool ReadColmapKeypointCounts(const std::string& database_path, std::unordered_map<std::string, int>* counts,
                              std::string* why);

// COLMAP's own minimum of inlier matches for a verified image pair
// (TwoViewGeometryOptions::min_num_inliers).
constexpr int kColmapMinInliers = 15;

// The image pairs (by name) whose two-view geometry holds at least
// `min_inliers` inlier matches: the pairs COLMAP verified. Read-only; false
// with `why` as ReadColmapKeypointCounts.
bool ReadColmapVerifiedPairs(const std::string& database_path, int min_inliers,
                             std::vector<std::pair<std::string, std::string>>* pairs, std::string* why);

// Copies the database `from` to `to` (replaced) without the keypoints and
// descriptors of the images named in `forget` and without the matches and
// two-view geometries of every pair holding one of them. COLMAP's feature
// extractor then extracts only those images again and its matchers match
// only those pairs (both skip what the database already holds). `forgotten`
// (may be null) gets how many of the names were images there. False with
// `why` (naming the file) when `from` cannot be read as a COLMAP database or
// `to` cannot be written; `to` is then removed.
bool CopyColmapDatabase(const std::string& from, const std::string& to, const std::vector<std::string>& forget,
                        int* forgotten, std::string* why);

}  // namespace rumi
