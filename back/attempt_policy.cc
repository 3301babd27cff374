#include "back/attempt_policy.h"

#include <algorithm>
#include <limits>
#include <unordered_set>

#include "back/blank_cut.h"
#include "back/model_to_submap.h"

namespace rumi {

bool ShortOfFrames(const ImageWindow& window, const WindowLayout& layout, const ColmapAttempt& a, double below) {
  std::vector<Timestamp> bounds = layout.part_bounds;
  bounds.push_back(std::numeric_limits<Timestamp>::max());
  Timestamp from = std::numeric_limits<Timestamp>::min();
  for (const Timestamp to : bounds) {
    int n = 0, best = 0;
    for (size_t i = 0; i < window.frames.size(); ++i)
      n += !layout.blank[i] && window.frames[i].timestamp >= from && window.frames[i].timestamp < to;
    for (const BuiltModel& b : a.built) {
      int in = 0;
      for (const Keyframe& k : b.submap.keyframes) in += k.timestamp >= from && k.timestamp < to;
      best = std::max(best, in);
    }
    if (n > 0 && best < below * n) return true;
    from = to;
  }
  return false;
}

std::vector<std::string> LeftOutFrames(const ImageWindow& window, const WindowLayout& layout, const ColmapAttempt& a,
                                       int margin) {
  const std::vector<Timestamp>& bounds = layout.part_bounds;
  const int n = int(window.frames.size());
  std::unordered_map<Timestamp, int> index;
  std::vector<size_t> part(n);
  for (int i = 0; i < n; ++i) {
    index[window.frames[i].timestamp] = i;
    part[i] = size_t(std::upper_bound(bounds.begin(), bounds.end(), window.frames[i].timestamp) - bounds.begin());
  }
  // Per part, the frames of its best model: the one holding most of it, the larger on a tie.
  std::vector<int> best(bounds.size() + 1, 0);
  std::vector<std::vector<int>> kept(bounds.size() + 1);
  for (const BuiltModel& b : a.built) {
    std::vector<std::vector<int>> in(bounds.size() + 1);
    for (const Keyframe& k : b.submap.keyframes) {
      const auto it = index.find(k.timestamp);
      if (it != index.end()) in[part[it->second]].push_back(it->second);
    }
    for (size_t p = 0; p < in.size(); ++p)
      if (int(in[p].size()) > best[p]) best[p] = int(in[p].size()), kept[p] = std::move(in[p]);
  }
  std::vector<bool> in_best(n, false);
  for (const auto& frames_of_part : kept)
    for (const int i : frames_of_part) in_best[i] = true;
  std::vector<bool> take(n, false);
  for (int i = 0; i < n; ++i)
    if (!layout.blank[i] && !in_best[i])
      for (int j = std::max(0, i - margin); j <= std::min(n - 1, i + margin); ++j) take[j] = !layout.blank[j];
  std::vector<std::string> names;
  for (int i = 0; i < n; ++i)
    if (take[i]) names.push_back(ColmapImageName(window.frames[i].timestamp));
  return names;
}

LeftOutCauses ClassifyLeftOut(const std::vector<std::string>& missing,
                              const std::unordered_map<std::string, int>& features,
                              const std::vector<std::pair<std::string, std::string>>& verified, int min_features) {
  const std::unordered_set<std::string> out(missing.begin(), missing.end());
  std::unordered_set<std::string> linked;  // frames left out verified with a frame kept
  for (const auto& [a, b] : verified) {
    if (out.count(a) && !out.count(b)) linked.insert(a);
    if (out.count(b) && !out.count(a)) linked.insert(b);
  }
  LeftOutCauses c;
  for (const std::string& name : missing) {
    const auto it = features.find(name);
    if (it == features.end() || it->second < min_features)
      ++c.poor;
    else
      c.unlinked += !linked.count(name);
  }
  return c;
}

bool RetryGoesFirst(const LeftOutCauses& c, size_t missing) {
  return c.poor + c.unlinked > 0 && 4 * (c.poor + c.unlinked) >= int(missing);
}

std::vector<BuiltModel> CutModels(std::vector<BuiltModel> built,
                                  const std::vector<std::pair<Timestamp, Timestamp>>& stretches, int min_keyframes,
                                  int min_point_observations, std::vector<std::string>* warnings) {
  std::vector<BuiltModel> cut;
  for (BuiltModel& b : built) {
    std::vector<Submap> pieces = CutAtStretches(b.submap, stretches, min_keyframes, min_point_observations);
    if (pieces.size() == 1 && pieces[0].keyframes.size() == b.submap.keyframes.size()) {
      cut.push_back(std::move(b));
      continue;
    }
    std::string sizes;
    for (Submap& p : pieces) {
      BuiltModel piece{std::move(p), b.stats};
      BackSubmapStats& st = piece.stats;
      st.registered_images = int(piece.submap.keyframes.size());
      st.num_points = int(piece.submap.points.size());
      st.num_observations = 0;
      for (const MapPoint& mp : piece.submap.points) st.num_observations += int(mp.observations.size());
      st.mean_track_length = st.num_points > 0 ? double(st.num_observations) / st.num_points : 0.0;
      sizes += (sizes.empty() ? "" : " + ") + std::to_string(st.registered_images);
      cut.push_back(std::move(piece));
    }
    if (warnings)
      warnings->push_back("a model of " + std::to_string(b.stats.registered_images) +
                          " frames cut at a blank stretch (the camera saw nothing): " +
                          (sizes.empty() ? "no side kept" : sizes + " frames kept"));
  }
  return cut;
}

void KeepBestSides(std::vector<ColmapAttempt> tried, const std::vector<std::pair<Timestamp, Timestamp>>& stretches,
                   int min_keyframes, int min_point_observations, ColmapAttempt* adopted_attempt,
                   std::vector<std::string>* warnings) {
  std::vector<std::vector<BuiltModel>> pieces;
  for (ColmapAttempt& a : tried)
    pieces.push_back(CutModels(std::move(a.built), stretches, min_keyframes, min_point_observations, nullptr));
  size_t adopted = 0;
  for (size_t k = 0; k < tried.size(); ++k)
    if (tried[k].name == adopted_attempt->name) {
      adopted = k;
      break;
    }
  pieces[adopted] =
      CutModels(std::move(adopted_attempt->built), stretches, min_keyframes, min_point_observations, warnings);
  std::vector<BuiltModel> kept;
  for (size_t side = 0; side <= stretches.size(); ++side) {
    const Timestamp from = side == 0 ? std::numeric_limits<Timestamp>::min() : stretches[side - 1].second;
    const Timestamp to = side == stretches.size() ? std::numeric_limits<Timestamp>::max() : stretches[side].first;
    const auto in_side = [&](const BuiltModel& b) {
      const Timestamp t = b.submap.keyframes.front().timestamp;
      return t > from && t < to;
    };
    size_t best = adopted;
    int best_size = 0;
    for (size_t k = 0; k < pieces.size(); ++k) {
      int size = 0;
      for (const BuiltModel& b : pieces[k])
        if (!b.submap.keyframes.empty() && in_side(b)) size = std::max(size, b.stats.registered_images);
      if (size > best_size) best = k, best_size = size;
    }
    if (best != adopted && best_size > 0)
      warnings->push_back("side " + std::to_string(side + 1) + " of the blank stretches: the " + tried[best].name +
                          "'s model of " + std::to_string(best_size) + " frames kept");
    for (BuiltModel& b : pieces[best])
      if (!b.submap.keyframes.empty() && in_side(b)) kept.push_back(std::move(b));
  }
  std::stable_sort(kept.begin(), kept.end(), [](const BuiltModel& x, const BuiltModel& y) {
    return x.stats.registered_images > y.stats.registered_images;
  });
  adopted_attempt->built = std::move(kept);
}

}  // namespace rumi
