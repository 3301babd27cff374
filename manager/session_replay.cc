#include "manager/session_replay.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <vector>

#include "common/process/process_info.h"
#include "manager/map_file.h"

namespace rumi {
namespace {

Timestamp LastTime(const Submap& s) {
  Timestamp t = 0;
  for (const Keyframe& kf : s.keyframes) t = std::max(t, kf.timestamp);
  for (const FrameRecord& f : s.frames) t = std::max(t, f.timestamp);
  return t;
}

// One submap as the manager receives it: a finished submap, or (a resend) a
// front submap still being built, cut at `at`.
struct SessionEvent {
  Timestamp at;
  int submap;
  bool resend;
};

// Submaps in the order they ended, with the resends among them.
std::vector<SessionEvent> SessionEvents(const GlobalMap& raw, const SessionReplayOptions& o) {
  std::vector<SessionEvent> events;
  for (size_t i = 0; i < raw.size(); ++i) {
    const Submap& s = raw.submap(int(i));
    events.push_back({LastTime(s), int(i), false});
    if (o.resend_interval_s <= 0 || s.source != SubmapSource::kFront || s.keyframes.empty()) continue;
    const Timestamp step = SecondsToNs(o.resend_interval_s);
    for (Timestamp t = s.keyframes.front().timestamp + step; t < LastTime(s); t += step) {
      const auto kfs = std::count_if(s.keyframes.begin(), s.keyframes.end(),
                                     [&](const Keyframe& kf) { return kf.timestamp <= t; });
      if (kfs >= o.resend_min_keyframes) events.push_back({t, int(i), true});
    }
  }
  std::stable_sort(events.begin(), events.end(),
                   [](const SessionEvent& a, const SessionEvent& b) { return a.at < b.at; });
  return events;
}

void PrintHeader() {
  std::cout << "rebuild\tsubmaps\tkeyframes\tkept\tcomponents\tcomputed\treplayed\ttotal_s\tcopy_s\tmerge_s\t"
               "place_s\todometry_s\tculling_s\tfront_search_s\trevisit_s\trevisit_fused\trevisit_replayed\t"
               "save_raw_s\tsave_map_s\toutputs_s\tframes\tbaked\trss_mib\n";
}

void PrintRebuild(const ManagerStats& st, size_t finished, double total_s) {
  const ManagerStats::Phases& p = st.last_rebuild_phases;
  std::cout << fmt::format("{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t{:.2f}\t"
                           "{:.2f}\t{}\t{}\t{:.2f}\t{:.2f}\t{:.2f}\t{}\t{}\t{:.0f}\n",
                           st.rebuilds, finished, st.saved_frames, st.saved_frames_postculled, st.components,
                           st.merge_attempts - st.merges_replayed, st.merges_replayed, total_s, p.copy, p.merge,
                           p.place, p.odometry, p.culling, st.culling.seconds_front_search,
                           st.culling.seconds_revisit, st.culling.revisit_fused,
                           st.culling.revisit_submaps_replayed, p.save_raw, p.save_map, p.outputs,
                           st.trajectory_frames, st.baked, ResidentMiB())
            << std::flush;
}

}  // namespace

bool ReplaySession(const GlobalMap& raw, const SessionReplayOptions& o, std::string* why) {
  const std::vector<SessionEvent> events = SessionEvents(raw, o);
  std::error_code ec;
  std::filesystem::remove(o.service.MapPath(), ec);
  std::filesystem::remove(o.service.MapPath() + ".raw", ec);
  std::filesystem::remove_all(RawBakedDir(o.service.MapPath() + ".raw"), ec);
  ManagerService service(o.service);
  if (!service.Start(why)) return false;
  PrintHeader();
  size_t finished = 0;
  for (size_t i = 0; i < events.size(); ++i) {
    const SessionEvent& e = events[i];
    service.AddSubmap(e.resend ? SubmapUntil(raw.submap(e.submap), e.at) : raw.submap(e.submap));
    finished += !e.resend;
    if ((i + 1) % size_t(o.rebuild_every) != 0 && i + 1 != events.size()) continue;
    const auto t0 = std::chrono::steady_clock::now();
    // The map file and the raw submaps as the manager's loop writes them.
    const bool map_files = i + 1 == events.size() ||
                           MapSaveDue(o.loop, service.SecondsSinceMapSave(), service.stats().last_map_save_seconds);
    if (!service.Rebuild(why, nullptr, {}, map_files)) return false;
    if (o.bake) {
      if (service.map_files_pending() && !service.WriteOutputs(why)) return false;
      service.BakeSettled(1e-9);
    }
    PrintRebuild(service.stats(), finished, SecondsSince(t0));
  }
  return true;
}

}  // namespace rumi
