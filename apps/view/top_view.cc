#include "apps/view/top_view.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>
#include <vector>

namespace rumi {
namespace {

Eigen::Vector2d Plane(const Eigen::Vector3d& p_global, const std::optional<Sim3>& S_gm) {
  if (S_gm) {
    const Eigen::Vector3d g = *S_gm * p_global;
    return {g.x(), g.y()};
  }
  return {p_global.x(), p_global.z()};  // camera convention: y down, z ahead
}

int32_t Mm(double m) { return static_cast<int32_t>(std::lround(m * 1000.0)); }

std::string KindOf(const std::string& submap_key) { return submap_key.substr(0, submap_key.find('#')); }

// Every key of `to` whose value differs from `from`'s, and every key of
// `from` that `to` lacks.
template <class Map, class Encode>
void MapDelta(const Map& from, const Map& to, const Encode& encode, nlohmann::json* set, nlohmann::json* del) {
  *set = nlohmann::json::array();
  *del = nlohmann::json::array();
  for (const auto& [k, v] : to) {
    const auto it = from.find(k);
    if (it == from.end() || !(it->second == v)) set->push_back(encode(k, v));
  }
  for (const auto& [k, v] : from)
    if (!to.count(k)) del->push_back(k);
}

// The larger side of the box holding the 1st to 99th percentile of the
// points on each axis: a few stray far points do not coarsen every cell.
double RobustExtent(const std::vector<Eigen::Vector2d>& plane) {
  double extent = 0;
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<double> v;
    v.reserve(plane.size());
    for (const Eigen::Vector2d& p : plane) v.push_back(p[axis]);
    const size_t lo = v.size() / 100, hi = v.size() - 1 - v.size() / 100;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(lo), v.end());
    const double a = v[lo];
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(hi), v.end());
    extent = std::max(extent, v[hi] - a);
  }
  return extent;
}

}  // namespace

Eigen::Vector3d PlanePose(const Se3& T_wc, const std::optional<Sim3>& S_gm) {
  const Eigen::Vector2d c = Plane(T_wc.translation(), S_gm);
  // The camera's axis (z) a metre ahead, in the same plane.
  const Eigen::Vector2d ahead = Plane(T_wc.translation() + T_wc.rotation() * Eigen::Vector3d::UnitZ(), S_gm);
  const Eigen::Vector2d d = ahead - c;
  return {c.x(), c.y(), std::atan2(d.y(), d.x())};
}

TopView MakeTopView(const MapSnapshot& s, const std::optional<Sim3>& S_gm, int cells_across) {
  TopView v;
  v.seq = s.seq;
  v.frame = S_gm ? "grid" : "map";
  v.points = static_cast<int64_t>(s.points.size());
  std::vector<Eigen::Vector2d> plane;
  plane.reserve(s.points.size());
  for (const Eigen::Vector3f& p : s.points) plane.push_back(Plane(p.cast<double>(), S_gm));
  const double extent = plane.empty() ? 1.0 : std::max(RobustExtent(plane), 1e-6);
  // A power of two: the cells stay put while the map grows (until it doubles).
  v.cell_m = std::pow(2.0, std::ceil(std::log2(extent / std::max(1, cells_across))));
  for (const Eigen::Vector2d& p : plane)
    v.cells.insert({static_cast<int32_t>(std::floor(p.x() / v.cell_m)), static_cast<int32_t>(std::floor(p.y() / v.cell_m))});
  std::set<int> components;
  for (const SnapshotKeyframe& k : s.keyframes) {
    const Eigen::Vector3d pp = PlanePose(k.T_wc, S_gm);
    TopViewKeyframe t;
    t.x_mm = Mm(pp.x());
    t.y_mm = Mm(pp.y());
    t.yaw_deg = static_cast<int32_t>(std::lround(pp.z() * 180.0 / M_PI));
    t.component = k.component;
    v.keyframes[k.submap + ":" + std::to_string(k.id)] = t;
  }
  for (const SnapshotSubmap& m : s.submaps) {
    TopViewSubmap t;
    t.kind = KindOf(m.key);
    t.component = m.component;
    t.keyframes = m.keyframes;
    t.points = m.points;
    t.first_s = NsToSeconds(m.first);
    t.last_s = NsToSeconds(m.last);
    v.submaps[m.key] = t;
    components.insert(m.component);
  }
  v.components = static_cast<int>(components.size());
  for (const auto& [bk, b] : v.submaps) {
    if (b.kind != "back" || b.keyframes == 0) continue;
    for (const auto& [fk, f] : v.submaps)
      if (f.kind == "front" && f.keyframes > 0 && f.component == b.component && f.first_s <= b.last_s &&
          b.first_s <= f.last_s)
        v.links.insert({bk, fk});
  }
  return v;
}

TopView ShownTopView(const TopView& shown, const TopView& truth, int tolerance_cells) {
  if (tolerance_cells <= 0 || shown.seq == 0 || shown.frame != truth.frame || shown.cell_m != truth.cell_m)
    return truth;
  using Cell = std::pair<int32_t, int32_t>;
  using Offset = std::pair<int, int>;
  const auto shifted = [](const Cell& c, const Offset& o) { return Cell{c.first + o.first, c.second + o.second}; };
  // The shown cells no longer true, each free to stand for one new true
  // cell nearby; the new true cells, each to be matched with one.
  std::set<Cell> free;
  for (const Cell& c : shown.cells)
    if (!truth.cells.count(c)) free.insert(c);
  std::vector<Cell> fresh;
  for (const Cell& t : truth.cells)
    if (!shown.cells.count(t)) fresh.push_back(t);
  // The offsets within the tolerance, the most common first: a rebuild
  // moves a neighbourhood alike, so the offset most new cells share is the
  // move (each cell's nearest free one instead pairs neighbours up wrongly:
  // top_view_test's moved map sent 4.4 % of its cells again, 2.9 % so).
  std::vector<std::pair<int, Offset>> offsets;  // (-votes, offset)
  for (int dx = -tolerance_cells; dx <= tolerance_cells; ++dx)
    for (int dy = -tolerance_cells; dy <= tolerance_cells; ++dy) {
      if (dx == 0 && dy == 0) continue;
      int votes = 0;
      for (const Cell& t : fresh) votes += free.count(shifted(t, {dx, dy})) > 0;
      offsets.push_back({-votes, {dx, dy}});
    }
  std::sort(offsets.begin(), offsets.end());
  std::map<Cell, size_t> owner;  // a shown cell taken: the new cell it stands for
  std::vector<bool> matched(fresh.size(), false);
  for (const auto& [votes, o] : offsets) {
    if (votes == 0) break;
    for (size_t i = 0; i < fresh.size(); ++i) {
      if (matched[i] || !free.erase(shifted(fresh[i], o))) continue;
      owner[shifted(fresh[i], o)] = i;
      matched[i] = true;
    }
  }
  // A new cell left over takes a taken cell whose new cell can move to a
  // free one (one step of an augmenting path).
  for (size_t i = 0; i < fresh.size(); ++i)
    for (size_t a = 0; a < offsets.size() && !matched[i]; ++a) {
      const auto it = owner.find(shifted(fresh[i], offsets[a].second));
      if (it == owner.end()) continue;
      for (size_t b = 0; b < offsets.size() && !matched[i]; ++b) {
        const Cell other = shifted(fresh[it->second], offsets[b].second);
        if (!free.erase(other)) continue;
        owner[other] = it->second;
        it->second = i;
        matched[i] = true;
      }
    }
  TopView next = truth;
  for (const auto& [c, i] : owner) {
    next.cells.erase(fresh[i]);
    next.cells.insert(c);
  }
  const int32_t tolerance_mm = Mm(tolerance_cells * truth.cell_m);
  for (auto& [key, k] : next.keyframes) {
    const auto it = shown.keyframes.find(key);
    if (it == shown.keyframes.end()) continue;
    const TopViewKeyframe& s = it->second;
    const int turn = std::abs((k.yaw_deg - s.yaw_deg + 540) % 360 - 180);
    if (s.component == k.component && std::abs(s.x_mm - k.x_mm) <= tolerance_mm &&
        std::abs(s.y_mm - k.y_mm) <= tolerance_mm && turn <= kShownTurnDeg)
      k = s;
  }
  return next;
}

nlohmann::json TopViewDelta(const TopView& from_in, const TopView& to) {
  static const TopView kEmpty;
  const bool reset = from_in.seq == 0 || from_in.frame != to.frame || from_in.cell_m != to.cell_m;
  const TopView& from = reset ? kEmpty : from_in;
  nlohmann::json j = {{"seq", to.seq},         {"base", reset ? 0 : from.seq}, {"frame", to.frame},
                      {"cell_m", to.cell_m},   {"reset", reset},
                      {"counts", {{"points", to.points}, {"keyframes", to.keyframes.size()},
                                  {"submaps", to.submaps.size()}, {"components", to.components},
                                  {"links", to.links.size()}}}};
  // Cells as flat [x0, y0, x1, y1, ...]: half the bytes of pairs.
  nlohmann::json add = nlohmann::json::array(), del = nlohmann::json::array();
  for (const auto& c : to.cells)
    if (!from.cells.count(c)) add.insert(add.end(), {c.first, c.second});
  for (const auto& c : from.cells)
    if (!to.cells.count(c)) del.insert(del.end(), {c.first, c.second});
  j["cells_add"] = std::move(add);
  j["cells_del"] = std::move(del);
  MapDelta(from.keyframes, to.keyframes,
           [](const std::string& k, const TopViewKeyframe& f) {
             return nlohmann::json::array({k, f.x_mm, f.y_mm, f.yaw_deg, f.component});
           },
           &j["kf_set"], &j["kf_del"]);
  MapDelta(from.submaps, to.submaps,
           [](const std::string& k, const TopViewSubmap& m) {
             return nlohmann::json::array({k, m.kind, m.component, m.keyframes, m.points, m.first_s, m.last_s});
           },
           &j["sm_set"], &j["sm_del"]);
  nlohmann::json links = nlohmann::json::array();  // few: always whole
  for (const auto& [a, b] : to.links) links.push_back({a, b});
  j["links"] = std::move(links);
  return j;
}

std::optional<Sim3> MapToGridFromYaml(const std::string& yaml) {
  try {
    const YAML::Node n = YAML::Load(yaml)["rumi_map_to_grid"];
    if (!n) return std::nullopt;
    const YAML::Node q = n["q_xyzw"], t = n["t"];
    return Sim3(n["s"].as<double>(),
                Eigen::Quaterniond(q[3].as<double>(), q[0].as<double>(), q[1].as<double>(), q[2].as<double>()),
                Eigen::Vector3d(t[0].as<double>(), t[1].as<double>(), t[2].as<double>()));
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

}  // namespace rumi
