#include "manager/grid/grid_file.h"

#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "common/atomic_file.h"
#include "common/trajectory_plot.h"

namespace rumi {
namespace fs = std::filesystem;

namespace {

uint8_t Pixel(CellState s) {
  switch (s) {
    case CellState::kFree: return kPgmFree;
    case CellState::kOccupied: return kPgmOccupied;
    case CellState::kUnknown: break;
  }
  return kPgmUnknown;
}

// Image row 0 is the grid's top row (largest y), as map_server reads it.
std::vector<uint8_t> Pixels(const OccupancyGrid& g) {
  std::vector<uint8_t> px(static_cast<size_t>(g.width()) * g.height());
  for (int row = 0; row < g.height(); ++row)
    for (int col = 0; col < g.width(); ++col)
      px[static_cast<size_t>(g.height() - 1 - row) * g.width() + col] =
          Pixel(g.State(col, row, kOccupiedThresh, kFreeThresh));
  return px;
}

// Skips whitespace and '#' comments between PGM header fields.
bool PgmField(const std::vector<uint8_t>& b, size_t* i, long* v) {
  while (*i < b.size()) {
    if (b[*i] == '#') {
      while (*i < b.size() && b[*i] != '\n') ++*i;
    } else if (std::isspace(b[*i])) {
      ++*i;
    } else {
      break;
    }
  }
  size_t start = *i;
  long x = 0;
  while (*i < b.size() && std::isdigit(b[*i]) && *i - start < 9) x = x * 10 + (b[(*i)++] - '0');
  if (*i == start) return false;
  *v = x;
  return true;
}

}  // namespace

MapServerGrid ToMapServerGrid(const OccupancyGrid& grid) {
  MapServerGrid g;
  g.resolution = grid.resolution();
  g.origin = Eigen::Vector3d(grid.origin().x(), grid.origin().y(), 0);
  g.width = grid.width();
  g.height = grid.height();
  g.pixels = Pixels(grid);
  return g;
}

std::string MapServerYaml(const MapServerGrid& g, const std::string& image, const std::vector<std::string>& extra) {
  std::ostringstream y;
  y.precision(10);
  y << "image: " << image << "\n"
    << "mode: " << g.mode << "\n"
    << "resolution: " << g.resolution << "\n"
    << "origin: [" << g.origin.x() << ", " << g.origin.y() << ", " << g.origin.z() << "]\n"
    << "negate: " << g.negate << "\n"
    << "occupied_thresh: " << g.occupied_thresh << "\n"
    << "free_thresh: " << g.free_thresh << "\n";
  for (const std::string& line : extra) y << line << "\n";
  return y.str();
}

bool WriteMapServerGrid(const MapServerGrid& g, const std::string& pgm_path, const std::string& yaml_path,
                        const std::vector<std::string>& extra, std::string* why) {
  if (g.width == 0 || g.height == 0) {
    *why = "the grid is empty: nothing was observed";
    return false;
  }
  const std::string header =
      "P5\n# rumi occupancy grid\n" + std::to_string(g.width) + " " + std::to_string(g.height) + "\n255\n";
  std::vector<uint8_t> bytes(header.begin(), header.end());
  bytes.insert(bytes.end(), g.pixels.begin(), g.pixels.end());
  if (!WriteFileAtomically(pgm_path, bytes, why)) return false;
  return WriteFileAtomically(yaml_path, MapServerYaml(g, fs::path(pgm_path).filename().string(), extra), why);
}

bool WriteMapServerGrid(const OccupancyGrid& grid, const std::string& pgm_path, const std::string& yaml_path,
                        const std::vector<std::string>& extra, std::string* why) {
  return WriteMapServerGrid(ToMapServerGrid(grid), pgm_path, yaml_path, extra, why);
}

bool ReadMapServerGrid(const std::string& yaml_path, MapServerGrid* out, std::string* why) {
  MapServerGrid g;
  try {
    const YAML::Node y = YAML::LoadFile(yaml_path);
    for (const char* key : {"image", "resolution", "origin", "occupied_thresh", "free_thresh"})
      if (!y[key]) {
        *why = yaml_path + ": no '" + key + "'";
        return false;
      }
    g.image = y["image"].as<std::string>();
    g.resolution = y["resolution"].as<double>();
    const auto o = y["origin"].as<std::vector<double>>();
    if (o.size() != 3) {
      *why = yaml_path + ": origin must be [x, y, yaw]";
      return false;
    }
    g.origin = Eigen::Vector3d(o[0], o[1], o[2]);
    g.negate = y["negate"] ? y["negate"].as<int>() : 0;
    g.occupied_thresh = y["occupied_thresh"].as<double>();
    g.free_thresh = y["free_thresh"].as<double>();
    if (y["mode"]) g.mode = y["mode"].as<std::string>();
  } catch (const YAML::Exception& e) {
    *why = yaml_path + ": " + e.what();
    return false;
  }
  if (!(g.resolution > 0)) {
    *why = yaml_path + ": resolution must be > 0";
    return false;
  }
  fs::path image = g.image;
  if (image.is_relative()) image = fs::path(yaml_path).parent_path() / image;
  std::vector<uint8_t> b;
  if (!ReadFileBytes(image.string(), &b, why)) return false;
  size_t i = 2;
  long w = 0, h = 0, maxval = 0;
  if (b.size() < 2 || b[0] != 'P' || b[1] != '5' || !PgmField(b, &i, &w) || !PgmField(b, &i, &h) ||
      !PgmField(b, &i, &maxval) || i >= b.size() || !std::isspace(b[i])) {
    *why = image.string() + ": not a binary PGM (P5) header";
    return false;
  }
  ++i;  // the one whitespace byte after maxval
  if (maxval != 255 || w <= 0 || h <= 0 || b.size() - i != static_cast<size_t>(w) * h) {
    *why = image.string() + ": expected " + std::to_string(w) + "x" + std::to_string(h) +
           " 8-bit pixels, maxval 255 (maxval " + std::to_string(maxval) + ", " + std::to_string(b.size() - i) +
           " bytes)";
    return false;
  }
  g.width = static_cast<int>(w);
  g.height = static_cast<int>(h);
  g.pixels.assign(b.begin() + static_cast<long>(i), b.end());
  *out = std::move(g);
  return true;
}

bool WriteGridPreview(const OccupancyGrid& grid, const std::vector<Eigen::Vector2d>& trajectory,
                      const std::string& png_path, std::string* why) {
  if (grid.width() == 0 || grid.height() == 0) {
    *why = "the grid is empty: nothing was observed";
    return false;
  }
  const std::vector<uint8_t> px = Pixels(grid);
  cv::Mat gray(grid.height(), grid.width(), CV_8UC1, const_cast<uint8_t*>(px.data()));
  cv::Mat img;
  cv::cvtColor(gray, img, cv::COLOR_GRAY2BGR);
  auto pixel = [&](const Eigen::Vector2d& p) {
    const Eigen::Vector2d c = (p - grid.origin()) / grid.resolution();
    return cv::Point(static_cast<int>(c.x()), grid.height() - 1 - static_cast<int>(c.y()));
  };
  for (size_t k = 1; k < trajectory.size(); ++k)
    cv::line(img, pixel(trajectory[k - 1]), pixel(trajectory[k]), cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
  if (!trajectory.empty()) cv::circle(img, pixel(trajectory.front()), 3, cv::Scalar(0, 160, 0), cv::FILLED);
  try {
    WritePng(png_path, img);
  } catch (const std::exception& e) {
    *why = e.what();
    return false;
  }
  return true;
}

}  // namespace rumi
