#include "common/loss_to_merge.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace rumi {
namespace {

bool Tracked(TrackingState s) { return s == TrackingState::kTracking || s == TrackingState::kCoarse; }

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
}

}  // namespace

std::vector<LossToMerge> ComputeLossToMerge(const std::vector<FrontFrameLine>& frames,
                                            const std::vector<BackSubmapTimes>& back) {
  std::vector<LossToMerge> losses;
  bool tracked_once = false, in_loss = false;
  for (const FrontFrameLine& f : frames) {
    if (Tracked(f.state)) {
      tracked_once = true;
      in_loss = false;
      continue;
    }
    if (!in_loss) {
      if (!tracked_once || f.skipped) continue;  // start-up, or a frame the replay dropped
      if (!f.wall) return {};
      LossToMerge l;
      l.first = f.t;
      l.lost_wall = *f.wall;
      losses.push_back(l);
      in_loss = true;
    }
    losses.back().last = f.t;
    ++losses.back().frames;
  }
  for (LossToMerge& l : losses) {
    for (const BackSubmapTimes& b : back) {
      if (!b.joined_wall) continue;
      const auto it = std::lower_bound(b.keyframes.begin(), b.keyframes.end(), l.first);
      if (it == b.keyframes.end() || *it > l.last) continue;  // holds none of the lost frames
      const double s = NsToSeconds(*b.joined_wall - l.lost_wall);
      if (!l.seconds || s < *l.seconds) {
        l.seconds = s;
        l.back_submap = b.id;
      }
    }
  }
  return losses;
}

std::vector<BackSubmapTimes> ReadBackSubmapTimes(const std::string& back_stats_path,
                                                 const std::string& manager_stats_path) {
  const nlohmann::json back = ReadJson(back_stats_path), manager = ReadJson(manager_stats_path);
  auto fail = [](const std::string& path, const std::string& why) { throw std::runtime_error(path + ": " + why); };
  std::map<int64_t, Timestamp> joined;
  if (manager.contains("back_submap_times")) {
    const nlohmann::json& a = manager["back_submap_times"];
    if (!a.is_array()) fail(manager_stats_path, "key 'back_submap_times' is not an array");
    for (const auto& e : a) {
      if (!e.is_object() || !e.contains("id") || !e["id"].is_number_integer() || !e.contains("joined_wall_s"))
        fail(manager_stats_path, "back_submap_times: each entry needs an integer 'id' and 'joined_wall_s'");
      if (e["joined_wall_s"].is_null()) continue;
      if (!e["joined_wall_s"].is_number() || !std::isfinite(e["joined_wall_s"].get<double>()))
        fail(manager_stats_path, "back_submap_times: 'joined_wall_s' is not a number");
      joined[e["id"].get<int64_t>()] = static_cast<Timestamp>(std::llround(e["joined_wall_s"].get<double>() * 1e9));
    }
  }
  std::vector<BackSubmapTimes> out;
  if (!back.contains("per_window")) return out;  // a back that reports no windows
  if (!back["per_window"].is_array()) fail(back_stats_path, "key 'per_window' is not an array");
  for (const auto& w : back["per_window"]) {
    if (!w.contains("submaps") || !w.contains("submap_timestamps")) continue;
    const auto &ids = w["submaps"], &stamps = w["submap_timestamps"];
    if (!ids.is_array() || !stamps.is_array() || ids.size() != stamps.size())
      fail(back_stats_path, "per_window: 'submaps' and 'submap_timestamps' must be arrays of one size");
    for (size_t k = 0; k < ids.size(); ++k) {
      if (!ids[k].is_number_integer() || !stamps[k].is_array())
        fail(back_stats_path, "per_window: a submap id is not an integer or its timestamps not an array");
      BackSubmapTimes b;
      b.id = ids[k].get<int64_t>();
      for (const auto& t : stamps[k]) {
        Timestamp ns = 0;
        if (!t.is_string() || !ParseSecondsToNs(t.get<std::string>(), &ns))
          fail(back_stats_path, "per_window: submap " + std::to_string(b.id) + " has a bad keyframe timestamp");
        b.keyframes.push_back(ns);
      }
      std::sort(b.keyframes.begin(), b.keyframes.end());
      const auto it = joined.find(b.id);
      if (it != joined.end()) b.joined_wall = it->second;
      out.push_back(std::move(b));
    }
  }
  return out;
}

LossToMergeSummary SummarizeLossToMerge(const std::vector<LossToMerge>& losses) {
  LossToMergeSummary s;
  s.losses = static_cast<int>(losses.size());
  std::vector<double> v;
  for (const LossToMerge& l : losses)
    if (l.seconds) v.push_back(*l.seconds);
  s.merged = static_cast<int>(v.size());
  if (v.empty()) return s;
  s.p50_s = Median(v);
  s.p95_s = PercentileNearestRank(v, 95);
  s.max_s = *std::max_element(v.begin(), v.end());
  return s;
}

}  // namespace rumi
