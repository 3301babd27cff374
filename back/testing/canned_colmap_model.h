#pragma once
// Test helpers for the back's process tests: a minimal COLMAP binary model
// as a fake `colmap mapper` would leave it, the fake `colmap` that leaves
// it, and a tiny window.
#include <sqlite3.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "common/camera.h"
#include "common/timestamp.h"
#include "common/window.h"

namespace rumi {

// Writes a model of one PINHOLE camera, images named by timestamp and one
// 3D point seen by every image at COLMAP pixel `px`. Image i's centre is at
// x = 0.1 i, except image `off_path`'s, 70 away.
inline void WriteCannedModel(const std::filesystem::path& dir, const PinholeCameraOptions& c,
                             const std::vector<Timestamp>& stamps, double px_x = 100.5, double px_y = 50.5,
                             int off_path = -1) {
  std::filesystem::create_directories(dir);
  auto put = [](std::ofstream& o, auto v) { o.write(reinterpret_cast<const char*>(&v), sizeof(v)); };
  {
    std::ofstream o(dir / "cameras.bin", std::ios::binary);
    put(o, uint64_t{1});
    put(o, uint32_t{1});
    put(o, int32_t{1});  // PINHOLE
    put(o, uint64_t(c.width));
    put(o, uint64_t(c.height));
    for (double v : {c.fx, c.fy, c.cx + 0.5, c.cy + 0.5}) put(o, v);
  }
  {
    std::ofstream o(dir / "images.bin", std::ios::binary);
    put(o, uint64_t(stamps.size()));
    for (size_t i = 0; i < stamps.size(); ++i) {
      put(o, uint32_t(i + 1));
      const double tx = int(i) == off_path ? 70.0 : -0.1 * double(i);
      for (double v : {1.0, 0.0, 0.0, 0.0, tx, 0.0, 0.0}) put(o, v);
      put(o, uint32_t{1});
      const std::string name = TimestampFileStem(stamps[i]) + ".png";
      o.write(name.c_str(), static_cast<std::streamsize>(name.size() + 1));
      put(o, uint64_t{1});
      for (double v : {px_x, px_y}) put(o, v);
      put(o, uint64_t{7});
    }
  }
  {
    std::ofstream o(dir / "points3D.bin", std::ios::binary);
    put(o, uint64_t{1});
    put(o, uint64_t{7});
    for (double v : {0.0, 0.0, 5.0}) put(o, v);
    for (uint8_t v : {1, 2, 3}) put(o, v);
    put(o, 0.5);
    put(o, uint64_t(stamps.size()));
    for (size_t i = 0; i < stamps.size(); ++i) {
      put(o, uint32_t(i + 1));
      put(o, uint32_t{0});
    }
  }
}

// Writes a COLMAP database (the tables and columns of COLMAP's schema that
// the back reads or edits) holding `keypoints`: image name -> keypoint rows,
// as many descriptor rows, and a matches and a two-view geometry row for
// every pair of images (rows: the smaller of the two counts).
inline bool WriteCannedColmapDatabase(const std::filesystem::path& path,
                                      const std::vector<std::pair<std::string, int>>& keypoints) {
  std::filesystem::remove(path);
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) return false;
  std::string sql =
      "CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, name TEXT NOT NULL UNIQUE, "
      "camera_id INTEGER NOT NULL);"
      "CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY NOT NULL, rows INTEGER NOT NULL, "
      "cols INTEGER NOT NULL, data BLOB);"
      "CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY NOT NULL, rows INTEGER NOT NULL, "
      "cols INTEGER NOT NULL, data BLOB);"
      "CREATE TABLE matches (pair_id INTEGER PRIMARY KEY NOT NULL, rows INTEGER NOT NULL, "
      "cols INTEGER NOT NULL, data BLOB);"
      "CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY NOT NULL, rows INTEGER NOT NULL, "
      "cols INTEGER NOT NULL, data BLOB, config INTEGER NOT NULL);";
  for (size_t i = 0; i < keypoints.size(); ++i) {
    const std::string id = std::to_string(i + 1), n = std::to_string(keypoints[i].second);
    sql += "INSERT INTO images VALUES (" + id + ", '" + keypoints[i].first + "', 1);";
    sql += "INSERT INTO keypoints VALUES (" + id + ", " + n + ", 6, NULL);";
    sql += "INSERT INTO descriptors VALUES (" + id + ", " + n + ", 128, NULL);";
    for (size_t j = 0; j < i; ++j) {
      const std::string pair = std::to_string(2147483647LL * int64_t(j + 1) + int64_t(i + 1));
      const std::string rows = std::to_string(std::min(keypoints[i].second, keypoints[j].second));
      sql += "INSERT INTO matches VALUES (" + pair + ", " + rows + ", 2, NULL);";
      sql += "INSERT INTO two_view_geometries VALUES (" + pair + ", " + rows + ", 2, NULL, 2);";
    }
  }
  const bool ok = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, nullptr) == SQLITE_OK;
  sqlite3_close(db);
  return ok;
}

// Writes <dir>/colmap.sh, a fake `colmap`: its mapper copies
// <dir>/canned/<stem of the first image>/ (a WriteCannedModel, if any) into
// the output. `feature_extractor_sh` is shell run first in every call (its
// step is in $cmd, <dir> in $d): a test makes the extraction hang or slow.
inline std::string WriteFakeColmap(const std::filesystem::path& dir, const std::string& feature_extractor_sh = "") {
  const std::filesystem::path script = dir / "colmap.sh";
  std::ofstream(script) << "#!/bin/sh\ncmd=$1\nout=''\nimg=''\nwhile [ $# -gt 0 ]; do\n"
                        << "  if [ \"$1\" = --output_path ]; then out=$2; fi\n"
                        << "  if [ \"$1\" = --image_path ]; then img=$2; fi\n  shift\ndone\n"
                        << "d=" << dir.string() << "\n"
                        << feature_extractor_sh
                        << "if [ $cmd = mapper ]; then first=$(ls $img | head -n 1);"
                        << " m=$d/canned/${first%.png}; if [ -d $m ]; then cp -r $m/* $out/; fi; fi\n";
  ::chmod(script.c_str(), 0755);
  return script.string();
}

// A 64x48 window of 4 frames of noise (seeded by id and i: not blank, which
// the back would leave out), 33.3 ms apart from t0 plus i ns (odd stamps must
// come back exactly).
inline ImageWindow TinyWindow(int64_t id, Timestamp t0) {
  ImageWindow w;
  w.id = id;
  w.camera.width = 64;
  w.camera.height = 48;
  w.camera.fx = 50;
  w.camera.fy = 52;
  w.camera.cx = 31.5;
  w.camera.cy = 23.25;
  for (int i = 0; i < 4; ++i) {
    WindowFrame f;
    f.timestamp = t0 + 33333333LL * i + i;
    f.image = cv::Mat(48, 64, CV_8UC1);
    cv::RNG rng(uint64_t(100 * id + i + 1));
    rng.fill(f.image, cv::RNG::UNIFORM, 0, 256);
    w.frames.push_back(f);
  }
  return w;
}

}  // namespace rumi
