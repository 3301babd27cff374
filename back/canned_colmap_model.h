#pragma once
// Test helper: writes a minimal COLMAP binary model (one PINHOLE camera,
// images named by timestamp, one 3D point seen by every image at COLMAP pixel
// `px`), as a fake `colmap mapper` would leave it.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "common/camera.h"
#include "common/timestamp.h"

namespace rumi {

inline void WriteCannedModel(const std::filesystem::path& dir, const PinholeCameraOptions& c,
                             const std::vector<Timestamp>& stamps, double px_x = 100.5, double px_y = 50.5) {
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
      for (double v : {1.0, 0.0, 0.0, 0.0, -0.1 * double(i), 0.0, 0.0}) put(o, v);
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

}  // namespace rumi
