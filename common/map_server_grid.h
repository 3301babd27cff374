#pragma once
// A 2D occupancy grid as ROS map_server holds it: an 8-bit image (254 free,
// 0 occupied, 205 unknown; first row = largest y) and the YAML keys beside
// it. The type the manager writes (manager/grid/grid_file.h) and the map
// service carries (ipc/dds), here so that both point down to it.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace rumi {

constexpr uint8_t kPgmFree = 254, kPgmOccupied = 0, kPgmUnknown = 205;
constexpr double kOccupiedThresh = 0.65, kFreeThresh = 0.196;

enum class CellState : uint8_t { kUnknown, kFree, kOccupied };

// A map_server grid as loaded from its YAML + image.
struct MapServerGrid {
  std::string image;  // as written in the YAML (relative to the YAML's folder)
  double resolution = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // x, y, yaw of the lower-left pixel
  int negate = 0;
  double occupied_thresh = kOccupiedThresh, free_thresh = kFreeThresh;
  std::string mode = "trinary";
  int width = 0, height = 0;
  std::vector<uint8_t> pixels;  // row-major, row 0 = top (largest y)
  // map_server's reading of a cell (col, row from the bottom, as the grid's).
  CellState State(int col, int row) const;
};

}  // namespace rumi
