#include "common/map_server_grid.h"

namespace rumi {

CellState MapServerGrid::State(int col, int row) const {
  const uint8_t v = pixels[static_cast<size_t>(height - 1 - row) * width + col];
  const double p = negate ? v / 255.0 : (255.0 - v) / 255.0;
  if (p > occupied_thresh) return CellState::kOccupied;
  if (p < free_thresh) return CellState::kFree;
  return CellState::kUnknown;
}

}  // namespace rumi
