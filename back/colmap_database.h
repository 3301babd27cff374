#pragma once
// Reads what the back needs from a COLMAP database (SQLite, the schema of
// COLMAP's database.cc): how many SIFT keypoints each image got. The back
// uses it to tell texture-poor frames (few features at the SIFT threshold:
// the retry at a lower one registers them) from frames the selected pairs
// left unlinked (the fill registers them).
#include <string>
#include <unordered_map>

namespace rumi {

// Image name -> keypoint count, for every image with a keypoints row.
// Opens the database read-only. False with `why` (naming the file) when it
// cannot be opened or has no images/keypoints tables.
bool ReadColmapKeypointCounts(const std::string& database_path, std::unordered_map<std::string, int>* counts,
                              std::string* why);

}  // namespace rumi
