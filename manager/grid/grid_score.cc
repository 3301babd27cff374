#include "manager/grid/grid_score.h"

#include <cmath>
#include <opencv2/core.hpp>

#include "common/trajectory_plot.h"

namespace rumi {

MapServerGrid RasterizeFloorPlan(const std::function<double(const Eigen::Vector3d&)>& clearance,
                                 const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, double resolution,
                                 double z_lo, double z_hi) {
  MapServerGrid g;
  g.resolution = resolution;
  g.origin = Eigen::Vector3d(lo.x(), lo.y(), 0);
  g.width = static_cast<int>(std::ceil((hi.x() - lo.x()) / resolution));
  g.height = static_cast<int>(std::ceil((hi.y() - lo.y()) / resolution));
  g.pixels.assign(static_cast<size_t>(g.width) * g.height, kPgmUnknown);
  const double half = resolution * std::sqrt(2.0) / 2;
  // Sample heights from half a diagonal above the band's bottom: a surface
  // below the band (the floor) must not reach a cell through the tolerance.
  z_lo = std::min(z_lo + half, z_hi);
  const int layers = std::max(2, static_cast<int>(std::ceil((z_hi - z_lo) / resolution)) + 1);
  for (int row = 0; row < g.height; ++row)
    for (int col = 0; col < g.width; ++col) {
      const Eigen::Vector2d c = lo + resolution * Eigen::Vector2d(col + 0.5, row + 0.5);
      bool near = false, blocked = false;  // blocked: inside a solid or outside the free space at some height
      for (int k = 0; k < layers && !near; ++k) {
        const double d = clearance({c.x(), c.y(), z_lo + (z_hi - z_lo) * k / (layers - 1)});
        near = std::abs(d) <= half;
        blocked = blocked || d < 0;
      }
      const uint8_t v = near ? kPgmOccupied : blocked ? kPgmUnknown : kPgmFree;
      g.pixels[static_cast<size_t>(g.height - 1 - row) * g.width + col] = v;
    }
  return g;
}

GridScore ScoreGrid(const MapServerGrid& est, const MapServerGrid& truth, const Sim3& S,
                    std::vector<CellMatch>* labels) {
  GridScore s;
  if (labels) labels->assign(static_cast<size_t>(truth.width) * truth.height, CellMatch::kNotCompared);
  int occ_inter = 0, occ_union = 0, free_inter = 0, free_union = 0, free_known = 0;
  for (int row = 0; row < truth.height; ++row)
    for (int col = 0; col < truth.width; ++col) {
      const CellState t = truth.State(col, row);
      if (t == CellState::kUnknown) continue;
      (t == CellState::kFree ? s.true_free : s.true_occupied)++;
      const Eigen::Vector3d p(truth.origin.x() + (col + 0.5) * truth.resolution,
                              truth.origin.y() + (row + 0.5) * truth.resolution, 0);
      const Eigen::Vector3d q = S * p;
      const int c = static_cast<int>(std::floor((q.x() - est.origin.x()) / est.resolution));
      const int r = static_cast<int>(std::floor((q.y() - est.origin.y()) / est.resolution));
      const CellState e =
          c >= 0 && r >= 0 && c < est.width && r < est.height ? est.State(c, r) : CellState::kUnknown;
      const bool wall = t == CellState::kOccupied;
      const CellMatch m = e == CellState::kUnknown ? (wall ? CellMatch::kWallUnknown : CellMatch::kFreeUnknown)
                          : e == CellState::kOccupied ? (wall ? CellMatch::kWallFound : CellMatch::kFreeAsWall)
                                                      : (wall ? CellMatch::kWallAsFree : CellMatch::kFreeFound);
      if (labels) (*labels)[static_cast<size_t>(row) * truth.width + col] = m;
      s.walls_found += m == CellMatch::kWallFound;
      s.walls_as_free += m == CellMatch::kWallAsFree;
      s.walls_unknown += m == CellMatch::kWallUnknown;
      s.false_walls += m == CellMatch::kFreeAsWall;
      if (e == CellState::kUnknown) continue;
      ++s.observed;
      if (t == CellState::kFree) ++free_known;
      occ_inter += e == CellState::kOccupied && t == CellState::kOccupied;
      occ_union += e == CellState::kOccupied || t == CellState::kOccupied;
      free_inter += e == CellState::kFree && t == CellState::kFree;
      free_union += e == CellState::kFree || t == CellState::kFree;
    }
  s.occupied_iou = occ_union ? static_cast<double>(occ_inter) / occ_union : 0;
  s.free_iou = free_union ? static_cast<double>(free_inter) / free_union : 0;
  s.coverage = s.true_free ? static_cast<double>(free_known) / s.true_free : 0;
  return s;
}

bool WriteGridComparison(const MapServerGrid& truth, const std::vector<CellMatch>& labels, const std::string& png_path,
                         std::string* why) {
  if (labels.size() != static_cast<size_t>(truth.width) * truth.height || labels.empty()) {
    *why = "no cells to draw";
    return false;
  }
  // BGR: free found white, free unknown light grey, false wall orange; wall
  // found black, wall called free red, wall unknown blue; not compared grey.
  auto colour = [](CellMatch m) {
    switch (m) {
      case CellMatch::kFreeFound: return cv::Vec3b(255, 255, 255);
      case CellMatch::kFreeUnknown: return cv::Vec3b(215, 215, 215);
      case CellMatch::kFreeAsWall: return cv::Vec3b(0, 140, 255);
      case CellMatch::kWallFound: return cv::Vec3b(0, 0, 0);
      case CellMatch::kWallAsFree: return cv::Vec3b(0, 0, 230);
      case CellMatch::kWallUnknown: return cv::Vec3b(200, 90, 0);
      default: return cv::Vec3b(128, 128, 128);
    }
  };
  cv::Mat img(truth.height, truth.width, CV_8UC3);
  for (int row = 0; row < truth.height; ++row)
    for (int col = 0; col < truth.width; ++col)
      img.at<cv::Vec3b>(truth.height - 1 - row, col) = colour(labels[static_cast<size_t>(row) * truth.width + col]);
  try {
    WritePng(png_path, img);
  } catch (const std::exception& e) {
    *why = e.what();
    return false;
  }
  return true;
}

}  // namespace rumi
