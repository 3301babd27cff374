#pragma once
// What the page draws of the map, seen from above: the main component's
// points as occupied cells (a subsample whose size does not grow with the
// points), every keyframe (position, heading, component), every submap
// (kind, component, time span) and the links that joined them. Encoded as a
// delta from the view the page already has, so a growing map sends what
// changed, not the whole map (docs/view.md).
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/geometry.h"
#include "ipc/dds/map_snapshot.h"

namespace rumi {

struct TopViewKeyframe {
  int32_t x_mm = 0, y_mm = 0;  // in the view's plane
  int32_t yaw_deg = 0;         // heading of the camera's axis in the plane
  int component = 0;
  bool operator==(const TopViewKeyframe& o) const {
    return x_mm == o.x_mm && y_mm == o.y_mm && yaw_deg == o.yaw_deg && component == o.component;
  }
};

struct TopViewSubmap {
  std::string kind;  // front | back
  int component = 0, keyframes = 0;
  int64_t points = 0;
  double first_s = 0, last_s = 0;  // keyframe time span, seconds
  bool operator==(const TopViewSubmap& o) const {
    return kind == o.kind && component == o.component && keyframes == o.keyframes && points == o.points &&
           first_s == o.first_s && last_s == o.last_s;
  }
};

struct TopView {
  int64_t seq = 0;
  // "grid": the occupancy grid's metric frame (x, y; z up), so the grid lies
  // under the map; "map": the global frame's x and z (no grid yet).
  std::string frame = "map";
  double cell_m = 0;
  std::set<std::pair<int32_t, int32_t>> cells;
  std::map<std::string, TopViewKeyframe> keyframes;  // "front#3:12"
  std::map<std::string, TopViewSubmap> submaps;      // "front#3"
  // A back submap and a front submap of one component whose frames overlap:
  // the back rebuilt the loss between them and the manager joined them there.
  std::set<std::pair<std::string, std::string>> links;
  int64_t points = 0;  // main component's points (before the cells)
  int components = 0;
};

// S_gm: the global frame -> the grid frame (from grid.yaml), when there is
// a grid. cells_across: about this many cells over the map's extent (its
// points' 1st to 99th percentile; a power-of-two size in metres, kept while
// the extent does not double).
TopView MakeTopView(const MapSnapshot& s, const std::optional<Sim3>& S_gm, int cells_across);

// The plane position (metres) and heading of a pose, as the top view draws it.
Eigen::Vector3d PlanePose(const Se3& T_wc, const std::optional<Sim3>& S_gm);

// What the page is shown next: `truth` (a new MakeTopView), except that
// what moved by at most `tolerance_cells` cells since `shown` stays where
// the page has it. A rebuild moves the whole map by a few centimetres (a
// merge, a loop correction), about a cell: sent as it is, half the cells
// and every keyframe would go out again at every rebuild (docs/view.md).
// The result holds exactly as many cells as `truth`, each the true cell it
// stands for or a shown one at most tolerance_cells from it (a one-to-one
// match: the true cells not in `shown` are matched with the shown cells no
// longer true, the most common move first), and each keyframe as in
// `truth` or, when it moved by at most tolerance_cells (each axis) and
// turned by at most kShownTurnDeg, as shown. tolerance_cells 0, a change of
// frame or cell size, or nothing shown yet: `truth` itself. The rest
// (submaps, links, counts, seq) is always `truth`'s.
constexpr int kShownTurnDeg = 5;
TopView ShownTopView(const TopView& shown, const TopView& truth, int tolerance_cells);

// The delta from `from` to `to`; from an empty view (seq 0) it is the whole
// view. A change of frame or cell size resets: the delta is the whole view.
nlohmann::json TopViewDelta(const TopView& from, const TopView& to);

// "grid.yaml"'s rumi_map_to_grid (global -> grid frame); nullopt without it.
std::optional<Sim3> MapToGridFromYaml(const std::string& yaml);

}  // namespace rumi
