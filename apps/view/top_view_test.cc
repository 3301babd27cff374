#include "apps/view/top_view.h"

#include <gtest/gtest.h>

#include <random>

namespace rumi {
namespace {

MapSnapshot Map(int points, int keyframes, uint32_t seed = 1) {
  MapSnapshot s;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-10, 10);
  for (int i = 0; i < points; ++i) s.points.emplace_back(u(rng), u(rng) * 0.1f, u(rng));
  for (int i = 0; i < keyframes; ++i) {
    SnapshotKeyframe k;
    k.id = i;
    k.submap = i < keyframes / 2 ? "front#1" : "front#2";
    k.component = i < keyframes / 2 ? 0 : 1;
    k.T_wc = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * i, 0, 0.05 * i));
    s.keyframes.push_back(k);
  }
  for (const char* key : {"front#1", "front#2", "back#7"}) {
    SnapshotSubmap m;
    m.key = key;
    m.keyframes = 10;
    m.component = std::string(key) == "front#2" ? 1 : 0;
    m.first = std::string(key) == "front#2" ? 20'000'000'000 : 0;
    m.last = m.first + 12'000'000'000;
    s.submaps.push_back(m);
  }
  return s;
}

// What the page does with a delta (view.js applyMap), to check the encoding.
void Apply(const nlohmann::json& d, TopView* v) {
  if (d["reset"].get<bool>()) *v = TopView();
  ASSERT_TRUE(d["reset"].get<bool>() || d["base"].get<int64_t>() == v->seq);
  const auto& add = d["cells_add"];
  for (size_t i = 0; i + 1 < add.size(); i += 2) v->cells.insert({add[i].get<int32_t>(), add[i + 1].get<int32_t>()});
  const auto& del = d["cells_del"];
  for (size_t i = 0; i + 1 < del.size(); i += 2) v->cells.erase({del[i].get<int32_t>(), del[i + 1].get<int32_t>()});
  for (const auto& k : d["kf_set"])
    v->keyframes[k[0]] = {k[1].get<int32_t>(), k[2].get<int32_t>(), k[3].get<int32_t>(), k[4].get<int>()};
  for (const auto& k : d["kf_del"]) v->keyframes.erase(k.get<std::string>());
  for (const auto& m : d["sm_set"])
    v->submaps[m[0]] = {m[1], m[2].get<int>(), m[3].get<int>(), m[4].get<int64_t>(), m[5].get<double>(), m[6].get<double>()};
  for (const auto& m : d["sm_del"]) v->submaps.erase(m.get<std::string>());
  v->seq = d["seq"];
  v->frame = d["frame"];
  v->cell_m = d["cell_m"];
}

TEST(TopView, CellsSubsampleThePointsAtAPowerOfTwoSize) {
  const TopView v = MakeTopView(Map(10000, 40), std::nullopt, 512);
  EXPECT_EQ(v.points, 10000);
  EXPECT_LT(v.cells.size(), 10000u);  // a subsample
  EXPECT_GT(v.cells.size(), 1000u);
  EXPECT_DOUBLE_EQ(std::log2(v.cell_m), std::round(std::log2(v.cell_m)));
  EXPECT_EQ(v.keyframes.size(), 40u);
  EXPECT_EQ(v.frame, "map");
  EXPECT_EQ(v.components, 2);
}

TEST(TopView, AFewStrayPointsDoNotCoarsenTheCells) {
  MapSnapshot s = Map(10000, 4);
  const TopView v = MakeTopView(s, std::nullopt, 512);
  s.points.emplace_back(5000.f, 0.f, 5000.f);  // a point triangulated far off
  const TopView w = MakeTopView(s, std::nullopt, 512);
  EXPECT_EQ(w.cell_m, v.cell_m);
  EXPECT_EQ(w.cells.size(), v.cells.size() + 1);  // drawn all the same
}

TEST(TopView, ABackSubmapIsLinkedToTheFrontSubmapsItOverlapsInItsComponent) {
  MapSnapshot s = Map(10, 4);
  s.submaps[1].component = 1;  // front#2 not joined
  s.submaps[2].first = 10'000'000'000;  // back#7 spans front#1's end and front#2's start
  s.submaps[2].last = 22'000'000'000;
  TopView v = MakeTopView(s, std::nullopt, 512);
  EXPECT_EQ(v.links, (std::set<std::pair<std::string, std::string>>{{"back#7", "front#1"}}));
  s.submaps[1].component = 0;
  v = MakeTopView(s, std::nullopt, 512);
  EXPECT_EQ(v.links.size(), 2u);
}

TEST(TopView, ADeltaAppliedToThePreviousViewGivesTheNextOne) {
  TopView a = MakeTopView(Map(10000, 40, 1), std::nullopt, 512);
  a.seq = 1;
  MapSnapshot grown = Map(10000, 40, 1);
  const MapSnapshot more = Map(200, 0, 9);
  grown.points.insert(grown.points.end(), more.points.begin(), more.points.end());
  grown.keyframes.pop_back();                                        // culled
  grown.keyframes[3].T_wc = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(5, 0, 5));  // moved
  grown.submaps[0].keyframes = 11;
  TopView b = MakeTopView(grown, std::nullopt, 512);
  b.seq = 2;
  ASSERT_EQ(a.cell_m, b.cell_m);
  const nlohmann::json d = TopViewDelta(a, b);
  EXPECT_FALSE(d["reset"].get<bool>());
  EXPECT_EQ(d["kf_del"].size(), 1u);
  EXPECT_EQ(d["kf_set"].size(), 1u);
  EXPECT_EQ(d["sm_set"].size(), 1u);
  TopView applied = a;
  Apply(d, &applied);
  EXPECT_EQ(applied.cells, b.cells);
  EXPECT_EQ(applied.keyframes, b.keyframes);
  EXPECT_EQ(applied.submaps, b.submaps);
  // The figures docs/view.md quotes: a 10k-point map whole, and one update.
  const size_t whole = TopViewDelta(TopView(), b).dump().size(), delta = d.dump().size();
  std::cout << "10k points: whole view " << whole << " bytes, " << b.cells.size() << " cells; an update adding 200 "
            << "points and moving 2 keyframes: " << delta << " bytes\n";
  EXPECT_LT(delta * 5, whole);
}

// Whether every cell of `a` has one of `b` at most `cells` away (each axis).
bool EachNear(const std::set<std::pair<int32_t, int32_t>>& a, const std::set<std::pair<int32_t, int32_t>>& b,
              int cells) {
  for (const auto& c : a) {
    bool near = false;
    for (int dx = -cells; dx <= cells && !near; ++dx)
      for (int dy = -cells; dy <= cells && !near; ++dy) near = b.count({c.first + dx, c.second + dy}) > 0;
    if (!near) return false;
  }
  return true;
}

// The map as a rebuild leaves it: all of it moved by `T` (a merge, a loop correction).
MapSnapshot Moved(MapSnapshot s, const Se3& T) {
  for (Eigen::Vector3f& p : s.points) p = (T * p.cast<double>()).cast<float>();
  for (SnapshotKeyframe& k : s.keyframes) k.T_wc = T * k.T_wc;
  return s;
}

TEST(TopView, AMapMovedByAFewCentimetresSendsAFewCells) {
  TopView shown = MakeTopView(Map(10000, 40), std::nullopt, 512);
  shown.seq = 1;
  // 4 cm along x, 3 cm along z, turned 0.2 degrees (3.5 cm at the map's edge):
  // under a cell and a half of 6.25 cm.
  const Se3 T(Eigen::Quaterniond(Eigen::AngleAxisd(0.2 * M_PI / 180, Eigen::Vector3d::UnitY())),
              Eigen::Vector3d(0.04, 0, 0.03));
  TopView truth = MakeTopView(Moved(Map(10000, 40), T), std::nullopt, 512);
  truth.seq = 2;
  ASSERT_EQ(truth.cell_m, shown.cell_m);
  ASSERT_EQ(truth.cell_m, 0.0625);
  const TopView next = ShownTopView(shown, truth, 2);
  const nlohmann::json plain = TopViewDelta(shown, truth), d = TopViewDelta(shown, next);
  EXPECT_GT(plain["cells_add"].size() / 2, truth.cells.size() / 3) << "sent as it is: most cells again";
  EXPECT_EQ(plain["kf_set"].size(), 40u);
  EXPECT_LT(d["cells_add"].size() / 2, truth.cells.size() / 20);  // points that split or share a cell
  EXPECT_TRUE(d["kf_set"].empty());
  EXPECT_EQ(d["counts"], plain["counts"]);
  std::cout << "10k points moved 5 cm: " << plain.dump().size() << " bytes as they are (" << plain["cells_add"].size() / 2
            << " cells added), " << d.dump().size() << " bytes shown within 2 cells (" << d["cells_add"].size() / 2
            << " added, " << d["cells_del"].size() / 2 << " removed; " << shown.cells.size() << " -> "
            << truth.cells.size() << " cells)\n";
  EXPECT_LT(d.dump().size() * 10, plain.dump().size());
  // The page gets exactly what the hub holds...
  TopView applied = shown;
  Apply(d, &applied);
  EXPECT_EQ(applied.cells, next.cells);
  EXPECT_EQ(applied.keyframes, next.keyframes);
  // ...which is the true map within 2 cells: as many cells, each near a true one.
  EXPECT_EQ(next.cells.size(), truth.cells.size());
  EXPECT_TRUE(EachNear(next.cells, truth.cells, 2));
  EXPECT_TRUE(EachNear(truth.cells, next.cells, 2));
  for (const auto& [key, k] : next.keyframes) {
    EXPECT_LE(std::abs(k.x_mm - truth.keyframes.at(key).x_mm), 125) << key;
    EXPECT_LE(std::abs(k.y_mm - truth.keyframes.at(key).y_mm), 125) << key;
  }

  // A move past the tolerance, and new points, are sent; tolerance 0: every move.
  MapSnapshot further = Moved(Map(10000, 40), T);
  further.keyframes[3].T_wc = Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(5, 0, 5));
  const MapSnapshot more = Map(200, 0, 9);
  further.points.insert(further.points.end(), more.points.begin(), more.points.end());
  TopView truth3 = MakeTopView(further, std::nullopt, 512);
  truth3.seq = 3;
  const TopView next3 = ShownTopView(next, truth3, 2);
  const nlohmann::json d3 = TopViewDelta(next, next3);
  EXPECT_EQ(d3["kf_set"].size(), 1u);
  EXPECT_GE(d3["cells_add"].size() / 2, 150u);  // the new points' cells (a few fall on shown ones)
  EXPECT_EQ(next3.cells.size(), truth3.cells.size());
  EXPECT_TRUE(EachNear(next3.cells, truth3.cells, 2) && EachNear(truth3.cells, next3.cells, 2));
  const TopView exact = ShownTopView(next, truth3, 0);
  EXPECT_EQ(exact.cells, truth3.cells);
  EXPECT_EQ(exact.keyframes, truth3.keyframes);
}

TEST(TopView, AChangeOfCellSizeSendsTheWholeView) {
  TopView a = MakeTopView(Map(1000, 4), std::nullopt, 512);
  a.seq = 1;
  MapSnapshot far = Map(1000, 4);
  for (int i = 0; i < 100; ++i) far.points.emplace_back(500.f, 0.f, 500.f);  // the extent more than doubles
  TopView b = MakeTopView(far, std::nullopt, 512);
  b.seq = 2;
  ASSERT_NE(a.cell_m, b.cell_m);
  const nlohmann::json d = TopViewDelta(a, b);
  EXPECT_TRUE(d["reset"].get<bool>());
  TopView applied = a;
  Apply(d, &applied);
  EXPECT_EQ(applied.cells, b.cells);
}

TEST(TopView, TheGridFrameComesFromGridYaml) {
  const std::string yaml =
      "image: grid.pgm\nresolution: 0.05\n"
      "rumi_map_to_grid: {s: 2.000000000, q_xyzw: [0.0, 0.0, 0.0, 1.0], t: [1.0, 2.0, 0.5]}\n";
  const auto S = MapToGridFromYaml(yaml);
  ASSERT_TRUE(S.has_value());
  EXPECT_DOUBLE_EQ(S->scale(), 2.0);
  EXPECT_FALSE(MapToGridFromYaml("image: grid.pgm\n").has_value());
  EXPECT_FALSE(MapToGridFromYaml("rumi_map_to_grid: {s: x}").has_value());
  // In the grid frame the plane is (x, y): a point at global (1, 0, 0) lies at 2 * 1 + 1.
  const Eigen::Vector3d p = PlanePose(Se3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)), S);
  EXPECT_NEAR(p.x(), 3.0, 1e-9);
  EXPECT_NEAR(p.y(), 2.0, 1e-9);
}

}  // namespace
}  // namespace rumi
