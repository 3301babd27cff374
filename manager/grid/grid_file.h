#pragma once
// The grid as ROS map_server files: an 8-bit binary PGM (254 free, 0
// occupied, 205 unknown; first row = largest y) and a YAML beside it
// (image, resolution, origin, negate 0, occupied_thresh 0.65, free_thresh
// 0.196, mode trinary), plus what rumi adds under keys map_server ignores
// (the scale and "up" used, the map-to-grid transform). Read back by
// ReadMapServerGrid the way map_server interprets it.
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "common/map_server_grid.h"
#include "manager/grid/occupancy_grid.h"

namespace rumi {

// The grid's cells as map_server values, thresholds 0.65 / 0.196.
MapServerGrid ToMapServerGrid(const OccupancyGrid& grid);
// The YAML text naming `image`, with `extra` lines after map_server's keys.
std::string MapServerYaml(const MapServerGrid& grid, const std::string& image, const std::vector<std::string>& extra);
// Writes <pgm_path> and <yaml_path> (atomic each); the YAML names the PGM by
// its file name. `extra` holds additional YAML lines ("key: value").
bool WriteMapServerGrid(const MapServerGrid& grid, const std::string& pgm_path, const std::string& yaml_path,
                        const std::vector<std::string>& extra, std::string* why);
bool WriteMapServerGrid(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path,
                        const std::vector<std::string>& extra, std::string* why);
// Loads a YAML and the image it names; false with *why naming the file and
// the problem (missing key, bad header, size mismatch).
bool ReadMapServerGrid(const std::string& yaml_path, MapServerGrid* out, std::string* why);

// A PNG preview: free white, occupied black, unknown grey, the trajectory
// (grid-frame x, y) drawn in red, its start green.
bool WriteGridPreview(const OccupancyGrid& grid, const std::vector<Eigen::Vector2d>& trajectory,
                      const std::string& png_path, std::string* why);

}  // namespace rumi
