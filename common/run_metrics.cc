#include "common/run_metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "common/atomic_file.h"
#include "common/loss_to_merge.h"
#include "common/window.h"

namespace rumi {
namespace {

std::vector<Timestamp> Times(const Trajectory& traj) {
  std::vector<Timestamp> t;
  t.reserve(traj.size());
  for (const auto& p : traj) t.push_back(p.t);
  return t;
}

nlohmann::json OrNull(const std::optional<double>& v) {
  return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
}

std::ifstream OpenOrThrow(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  return in;
}

nlohmann::json ReadJsonObject(const std::string& path) {
  std::ifstream in = OpenOrThrow(path);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw std::runtime_error(path + ": expected a JSON object");
  return j;
}

double NumberKey(const nlohmann::json& j, const std::string& key, const std::string& path) {
  if (!j.contains(key)) throw std::runtime_error(path + ": missing key '" + key + "'");
  if (!j[key].is_number()) throw std::runtime_error(path + ": key '" + key + "' is not a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v) || v < 0) {
    throw std::runtime_error(path + ": key '" + key + "' must be a finite number >= 0");
  }
  return v;
}

int64_t CountKey(const nlohmann::json& j, const std::string& key, const std::string& path) {
  const double v = NumberKey(j, key, path);
  if (v != std::floor(v)) throw std::runtime_error(path + ": key '" + key + "' is not an integer");
  return static_cast<int64_t>(v);
}

// Splits a data line into fields; false for blank and '#' lines.
bool Fields(const std::string& line, std::vector<std::string>* fields) {
  fields->clear();
  std::istringstream ss(line);
  std::string f;
  while (ss >> f) fields->push_back(f);
  return !fields->empty() && (*fields)[0][0] != '#';
}

bool ParseInt(const std::string& s, int64_t* v) {
  if (s.empty()) return false;
  size_t pos = 0;
  try {
    *v = std::stoll(s, &pos);
  } catch (const std::exception&) {
    return false;
  }
  return pos == s.size();
}

}  // namespace


TrajectoryMetrics ComputeTrajectoryMetrics(const std::vector<Timestamp>& frames,
                                           const Trajectory& est, const Trajectory& gt,
                                           const AteOptions& ate,
                                           const TrackingRateOptions& rate_options) {
  TrajectoryMetrics m;
  const TrackingRate rate = ComputeTrackingRate(frames, Times(est), rate_options);
  m.rate_time = rate.covered_rate;
  m.rate_frames = rate.frame_rate;
  if (gt.empty()) {
    m.ate_note = "no ground truth";
  } else if (est.empty()) {
    m.ate_note = "empty trajectory";
  } else {
    try {
      const AteResult r = ComputeAte(est, gt, ate);
      m.ate_rmse = r.translation.rmse;
      m.ate_pairs = r.pairs.size();
      m.S_gt_est = r.S_gt_est;
      if (r.line_alignment) m.ate_note = "ground truth on a straight line: aligned along it";
    } catch (const std::exception& e) {
      m.ate_note = e.what();
    }
  }
  return m;
}

namespace {
// ATE of `est` over the poses whose timestamps `frames` also holds (within
// 1 ms); null when that is not computable.
std::optional<double> AteOnFrames(const Trajectory& est, const Trajectory& frames, const Trajectory& gt,
                                  const AteOptions& ate) {
  if (gt.empty() || est.empty() || frames.empty()) return std::nullopt;
  Trajectory kept;
  size_t k = 0;
  for (const StampedPose& p : est) {
    while (k < frames.size() && frames[k].t < p.t - 1000000) ++k;
    if (k < frames.size() && std::llabs(frames[k].t - p.t) <= 1000000) kept.push_back(p);
  }
  try {
    return ComputeAte(kept, gt, ate).translation.rmse;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}
}  // namespace

RunMetricsReport ComputeRunMetrics(const RunMetricsInput& in) {
  if (in.frames.size() < 2) {
    throw std::runtime_error("run metrics need the timestamps of at least 2 sequence frames (got " +
                             std::to_string(in.frames.size()) + ")");
  }
  RunMetricsReport r;
  r.sequence = in.sequence;
  r.frames = in.frames.size();
  r.duration_s = NsToSeconds(in.frames.back() - in.frames.front());
  r.front = ComputeTrajectoryMetrics(in.frames, in.front, in.ground_truth, in.ate, in.rate);
  r.merged = ComputeTrajectoryMetrics(in.frames, in.merged, in.ground_truth, in.ate, in.rate);
  r.merged_ate_front_frames = AteOnFrames(in.merged, in.front, in.ground_truth, in.ate);
  if (!in.components.empty()) {
    std::vector<Timestamp> posed;
    for (const Trajectory& c : in.components)
      for (const StampedPose& p : c) posed.push_back(p.t);
    std::sort(posed.begin(), posed.end());
    posed.erase(std::unique(posed.begin(), posed.end()), posed.end());
    r.components_rate_frames = ComputeTrackingRate(in.frames, posed, in.rate).frame_rate;
  }
  if (!in.front_ms.empty()) {
    double sum = 0;
    for (double x : in.front_ms) sum += x;
    r.front_ms_mean = sum / static_cast<double>(in.front_ms.size());
    r.front_ms_median = Median(in.front_ms);
    r.front_ms_p95 = PercentileNearestRank(in.front_ms, 95);
  }
  r.counts = in.counts;
  if (in.front.empty())
    r.warnings.push_back("the front tracked no frame (front.txt is empty): check the camera and the images");
  if (in.merged.empty()) r.warnings.push_back("the merged map holds no frame (merged.txt is empty)");
  if (in.counts.back_windows_failed > 0)
    r.warnings.push_back(std::to_string(in.counts.back_windows_failed) + " of " +
                         std::to_string(in.counts.back_windows) +
                         " back window(s) failed (back/back_stats.json per_window: status and message)");
  return r;
}

std::string FormatRunMetricsJson(const RunMetricsReport& r) {
  nlohmann::ordered_json j;
  j["sequence"] = r.sequence;
  j["frames"] = r.frames;
  j["duration_s"] = r.duration_s;
  j["front_tracking_rate_time"] = r.front.rate_time;
  j["front_tracking_rate_frames"] = r.front.rate_frames;
  j["merged_tracking_rate_time"] = r.merged.rate_time;
  j["merged_tracking_rate_frames"] = r.merged.rate_frames;
  j["front_ate_rmse"] = OrNull(r.front.ate_rmse);
  j["merged_ate_rmse"] = OrNull(r.merged.ate_rmse);
  j["front_ate_pairs"] = r.front.ate_pairs;
  j["merged_ate_pairs"] = r.merged.ate_pairs;
  j["front_ms_mean"] = OrNull(r.front_ms_mean);
  j["front_ms_median"] = OrNull(r.front_ms_median);
  j["front_ms_p95"] = OrNull(r.front_ms_p95);
  j["back_windows"] = r.counts.back_windows;
  j["back_seconds"] = r.counts.back_seconds;
  j["merges"] = r.counts.merges;
  j["saved_frames"] = r.counts.saved_frames;
  j["saved_frames_postculled"] = r.counts.saved_frames_postculled;
  j["submaps_front"] = r.counts.submaps_front;
  j["submaps_back"] = r.counts.submaps_back;
  j["front_saved_frames"] = r.counts.front_saved_frames;
  nlohmann::ordered_json notes = nlohmann::ordered_json::object();
  if (!r.front.ate_note.empty()) notes["front_ate"] = r.front.ate_note;
  if (!r.merged.ate_note.empty()) notes["merged_ate"] = r.merged.ate_note;
  if (!notes.empty()) j["notes"] = notes;
  j["merged_ate_front_frames"] = OrNull(r.merged_ate_front_frames);
  if (r.components_rate_frames) j["components_tracking_rate_frames"] = *r.components_rate_frames;
  if (r.merge_audit_done) {
    nlohmann::json audit = nlohmann::json::array();
    int rejected = 0, harmful = 0, rejected_harmful = 0;
    for (const MergeAuditRow& m : r.merge_audit) {
      rejected += !m.accepted;
      harmful += m.accepted && m.harmful;
      rejected_harmful += !m.accepted && m.harmful;
      nlohmann::json row = {{"kind", m.kind},
                            {"a", m.a},
                            {"b", m.b},
                            {"accepted", m.accepted},
                            {"a_frames", m.a_frames},
                            {"b_frames", m.b_frames},
                            {"ate_a", OrNull(m.ate_a)},
                            {"ate_b", OrNull(m.ate_b)},
                            {"ate_joint", OrNull(m.ate_joint)},
                            {"ate_a_joint", OrNull(m.ate_a_joint)},
                            {"harmful", m.harmful}};
      if (!m.accepted) row["reason"] = m.reason;
      if (!m.rejected_by.empty()) row["rejected_by"] = m.rejected_by;
      if (!m.note.empty()) row["note"] = m.note;
      audit.push_back(row);
    }
    j["merge_audit"] = audit;
    j["merges_rejected"] = rejected;
    j["merges_harmful"] = harmful;
    j["merges_rejected_harmful"] = rejected_harmful;
  }
  if (r.loop_audit_done) {
    nlohmann::json audit = nlohmann::json::array();
    int closed = 0, harmful = 0;
    for (const LoopAuditRow& l : r.loop_audit) {
      closed += l.closed;
      harmful += l.harmful;
      nlohmann::json row = {{"query", l.query},
                            {"query_keyframe", l.query_keyframe},
                            {"query_time_s", l.query_time_s},
                            {"match", l.match},
                            {"match_keyframe", l.match_keyframe},
                            {"match_time_s", l.match_time_s},
                            {"closed", l.closed},
                            {"rotation_error_deg", OrNull(l.rotation_error_deg)},
                            {"direction_error_deg", OrNull(l.direction_error_deg)},
                            {"right", l.right},
                            {"harmful", l.harmful}};
      if (!l.note.empty()) row["note"] = l.note;
      audit.push_back(row);
    }
    j["loop_audit"] = audit;
    j["loops_closed"] = closed;
    j["loops_harmful"] = harmful;
  }
  if (r.loss_to_merge) {
    const LossToMergeSummary sum = SummarizeLossToMerge(*r.loss_to_merge);
    nlohmann::ordered_json per = nlohmann::ordered_json::array();
    for (const LossToMerge& l : *r.loss_to_merge)
      per.push_back({{"first", FormatSeconds(l.first)},
                     {"last", FormatSeconds(l.last)},
                     {"frames", l.frames},
                     {"seconds", OrNull(l.seconds)},
                     {"back_submap", l.back_submap}});
    j["losses"] = sum.losses;
    j["losses_merged"] = sum.merged;
    j["loss_to_merge_p50_s"] = OrNull(sum.p50_s);
    j["loss_to_merge_p95_s"] = OrNull(sum.p95_s);
    j["loss_to_merge_max_s"] = OrNull(sum.max_s);
    j["loss_to_merge"] = per;
  } else {
    j["losses"] = nullptr;
  }
  j["warnings"] = r.warnings;
  return j.dump(2) + "\n";
}

void WriteRunMetricsJson(const std::string& path, const RunMetricsReport& report) {
  std::string why;
  if (!WriteFileAtomically(path, FormatRunMetricsJson(report), &why)) throw std::runtime_error(why);
}

bool ParseTrackingState(const std::string& text, TrackingState* state) {
  static const std::pair<const char*, TrackingState> kNames[] = {
      {"initializing", TrackingState::kInitializing}, {"tracking", TrackingState::kTracking},
      {"lost", TrackingState::kLost},                 {"coarse", TrackingState::kCoarse},
      {"0", TrackingState::kInitializing},            {"1", TrackingState::kTracking},
      {"2", TrackingState::kLost},                    {"3", TrackingState::kCoarse}};
  for (const auto& [name, s] : kNames) {
    if (text == name) {
      *state = s;
      return true;
    }
  }
  return false;
}

std::vector<FrontFrameLine> ParseFrontFrames(std::istream& in, const std::string& name) {
  std::vector<FrontFrameLine> out;
  std::string line;
  std::vector<std::string> f;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!Fields(line, &f)) continue;
    auto fail = [&](const std::string& why) {
      throw std::runtime_error(name + ":" + std::to_string(n) + ": " + why);
    };
    if (f.size() < 3) fail("expected 't_seconds state submap_id [ms]'");
    FrontFrameLine r;
    if (!ParseSecondsToNs(f[0], &r.t)) fail("bad timestamp '" + f[0] + "'");
    if (!ParseTrackingState(f[1], &r.state)) fail("unknown tracking state '" + f[1] + "'");
    if (!ParseInt(f[2], &r.submap_id)) fail("bad submap id '" + f[2] + "'");
    if (f.size() >= 4) {
      char* stop = nullptr;
      const double ms = std::strtod(f[3].c_str(), &stop);
      if (stop != f[3].c_str() + f[3].size() || !std::isfinite(ms) || ms < 0) {
        fail("bad time in ms '" + f[3] + "'");
      }
      r.ms = ms;
    }
    if (f.size() >= 6) {
      if (f[5] != "0" && f[5] != "1") fail("skipped column must be 0 or 1, got '" + f[5] + "'");
      r.skipped = f[5] == "1";
    }
    if (f.size() >= 7) {
      Timestamp wall = 0;
      if (!ParseSecondsToNs(f[6], &wall)) fail("bad wall-clock time '" + f[6] + "'");
      r.wall = wall;
    }
    if (!out.empty() && r.t <= out.back().t) fail("timestamps not strictly increasing");
    out.push_back(r);
  }
  return out;
}

std::vector<FrontFrameLine> ReadFrontFrames(const std::string& path) {
  std::ifstream in = OpenOrThrow(path);
  return ParseFrontFrames(in, path);
}

std::vector<FrontSampleLine> ParseFrontSamples(std::istream& in, const std::string& name) {
  std::vector<FrontSampleLine> out;
  std::string line;
  std::vector<std::string> f;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!Fields(line, &f)) continue;
    auto fail = [&](const std::string& why) {
      throw std::runtime_error(name + ":" + std::to_string(n) + ": " + why);
    };
    if (f.size() < 3) fail("expected 't_seconds set window_id'");
    FrontSampleLine s;
    if (!ParseSecondsToNs(f[0], &s.t)) fail("bad timestamp '" + f[0] + "'");
    SampleSet set;
    if (!ParseSampleSet(f[1], &set)) fail("set must be 1, 2, 3 (or S1..S3), got '" + f[1] + "'");
    s.set = int(set);
    if (!ParseInt(f[2], &s.window_id)) fail("bad window id '" + f[2] + "'");
    out.push_back(s);
  }
  return out;
}

std::vector<FrontSampleLine> ReadFrontSamples(const std::string& path) {
  std::ifstream in = OpenOrThrow(path);
  return ParseFrontSamples(in, path);
}

void ReadBackStats(const std::string& path, RunCounts* c) {
  const nlohmann::json j = ReadJsonObject(path);
  c->back_windows = CountKey(j, "windows", path);
  c->back_seconds = NumberKey(j, "seconds", path);
  if (j.contains("windows_failed")) c->back_windows_failed = CountKey(j, "windows_failed", path);
}

void ReadManagerStats(const std::string& path, RunCounts* c) {
  const nlohmann::json j = ReadJsonObject(path);
  c->merges = CountKey(j, "merges", path);
  c->saved_frames = CountKey(j, "saved_frames", path);
  c->saved_frames_postculled = CountKey(j, "saved_frames_postculled", path);
  c->submaps_front = CountKey(j, "submaps_front", path);
  c->submaps_back = CountKey(j, "submaps_back", path);
}

void ReadFrontStats(const std::string& path, RunCounts* c) {
  const nlohmann::json j = ReadJsonObject(path);
  c->front_saved_frames = CountKey(j, "saved_frames", path);
  c->submaps_front = CountKey(j, "submaps", path);
}

}  // namespace rumi
