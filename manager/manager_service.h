#pragma once
// The rumi-manager process logic, usable in-process (tests) and by
// manager_main.cc: keeps the latest version of every submap, rebuilds the
// global map (MergeAll + post-culling) when something changed, and writes the
// map file, the global trajectories and manager_stats.json into the out dir.
//
// Rebuild policy: every received submap is kept as it arrived (the latest
// version per (source, id); a front submap may be resent while it grows). A
// rebuild starts from the "base", the current map without the received
// submaps (what the map file brought at start, and the settled submaps baked
// into it, BakeSettled), adds every received submap in its own frame (or
// where the last map joined it to the base: CarryPlacements) and runs
// MergeAll, then culls. Simple and correct for
// resends. A MergeMemo replays the merges whose submaps did not change, so a
// rebuild computes only those of new or grown submaps; rebuilds are still
// rate-limited by the caller (RunManagerLoop, manager/manager_run.h).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "common/submap.h"
#include "manager/global_map.h"
#include "manager/grid/grid_builder.h"
#include "manager/loop_closure.h"
#include "manager/manager_options.h"
#include "manager/map_grid.h"
#include "manager/merge.h"
#include "manager/merge_memo.h"
#include "manager/place_merge.h"
#include "manager/post_culling.h"

namespace rumi {

struct ManagerServiceOptions {
  ManagerOptions manager;
  std::string out_dir;   // created when missing
  std::string map_path;  // empty: <out_dir>/map.rumi
  bool post_culling = true;
  // rumid: every submap received is written to <map>.received/ before the
  // ring slot is let go, so a manager killed between two saves loses none;
  // a restarted manager reloads them. Cleared after each raw save.
  bool journal = false;
  // The occupancy grid, rewritten with the map (grid.pgm/.yaml/.png,
  // grid_trajectory.txt in out_dir) when a metric frame can be had.
  GridOptions grid;
  std::string MapPath() const;
  std::string JournalDir() const;
};

struct ManagerStats {
  int64_t messages_front = 0, messages_back = 0;  // submaps received (resends included)
  int64_t resends = 0;                            // received again with a known (source, id)
  int64_t decode_errors = 0;                      // malformed messages dropped
  int64_t invalid_submaps = 0;                    // decoded but inconsistent: refused
  int64_t rebuilds = 0;
  int64_t journal_reloaded = 0;  // submaps reloaded from the journal at start
  std::string last_save;         // wall-clock time of the last map save (ISO 8601), "" before it
  int merges = 0;  // successful merges that built the current map (submaps - components)
  int merge_attempts = 0;  // MergePair calls of the last rebuild
  int merges_replayed = 0;  // of those, taken from the MergeMemo (submaps unchanged)
  int saved_frames = 0, saved_frames_postculled = 0;  // keyframes before / after culling
  int submaps_front = 0, submaps_back = 0, components = 0;
  int base_submaps = 0;  // submaps reloaded from the map file at start
  int64_t baked = 0;     // received submaps baked into the base (BakeSettled)
  int64_t front_submap_upto = -1;  // highest front submap id in the last rebuild
  Timestamp front_submap_upto_end = 0;  // its last frame
  int trajectory_frames = 0;  // frames of merged.txt
  double last_rebuild_seconds = 0;
  double last_map_save_seconds = 0;  // the last write of map.rumi + map.rumi.raw
  int64_t map_saves = 0;
  // Where the last rebuild's time went (seconds): the copy of the inputs,
  // the merges (back, place, odometry), the culling, and the writes.
  struct Phases {
    double copy = 0, merge = 0, place = 0, odometry = 0, loops = 0, culling = 0;
    double save_raw = 0, save_map = 0, outputs = 0;  // outputs: trajectories, grid, stats
  } last_rebuild_phases;
  std::string grid;  // the last grid's summary, or why there is none
  std::vector<MergeReport> reports;  // of the last rebuild (rejections included)
  CullingReport culling;
  LoopClosureReport loops;  // of the last rebuild
  // Per back submap received by this process: when it arrived and when it
  // was first in one component with a front submap (system clock, ns; 0 not
  // yet). With the front's wall_s column this gives `rumi eval run` its
  // loss-to-merge times (docs/eval.md).
  struct BackTimes {
    Timestamp received = 0, joined = 0;
  };
  std::map<int64_t, BackTimes> back_times;
};

class ManagerService {
 public:
  explicit ManagerService(ManagerServiceOptions options);

  // Creates the out dir and reloads the map file when present. A file that
  // does not load (truncated, foreign, corrupt) is logged, renamed to
  // <map>.bad (or .bad.N) and the service starts empty. False only when the
  // out dir cannot be created or a bad file cannot be moved aside.
  bool Start(std::string* why);

  // Keeps s as the latest version of (source, id) and marks the state dirty.
  // A submap that fails ValidateSubmap is logged, counted and refused (false).
  // With the journal, s is on disk when this returns true.
  bool AddSubmap(Submap s);
  void CountDecodeErrors(int64_t n) { stats_.decode_errors += n; }
  bool dirty() const { return dirty_; }
  // The last WriteOutputs failed (a full disk): the files on disk are the
  // previous ones, intact; saving again is due.
  bool unsaved() const { return unsaved_; }
  // The map file or the raw submaps are older than the map in memory (a
  // rebuild left them for later).
  bool map_files_pending() const { return map_dirty_ || raw_dirty_; }

  // Rebuilds the global map from the base and all received submaps, culls,
  // then writes the outputs. False (with why) when an output cannot be
  // written, or when *cancel was set (SIGTERM): then the rebuild is abandoned
  // whole, the map and the files stay as they were, and the state stays dirty.
  // on_rebuilt runs once the new map is in place, before the writes: what
  // waits on the map (a halted robot) need not wait on the disk, nor on a
  // save that fails.
  // map_files false: the map file and the raw submaps are left for a later
  // save (RunManagerLoop's MapSaveDue), the other outputs are written.
  bool Rebuild(std::string* why, const std::atomic<bool>* cancel = nullptr,
               const std::function<void()>& on_rebuilt = {}, bool map_files = true);
  // Writes map file (atomic), merged.txt, merged_<k>.txt (one per component,
  // largest first, merged_0 == merged.txt), manager_stats.json (all atomic).
  // map_files false: all but the map file and the raw submaps.
  bool WriteOutputs(std::string* why, bool map_files = true);
  // The incremental manager: received submaps that are settled leave the
  // received set for the base, in their merged and culled form from the
  // current map, so the map in memory grows with the place, not with the
  // session (a looped walk revisits one room: revisit fusion lets culling
  // drop the repeats, baking drops their raw copies; the map holds one
  // copy of the base, the received set the raw submaps). Settled: unchanged
  // for min_age_s, not the newest front submap (still growing), and in the
  // map file already (no rebuild or save pending), so a restart finds it
  // there. A window that comes later still pairs with a baked front submap
  // through its tracked frames (pair_tracked_frames). Returns how many were
  // baked; 0 with min_age_s <= 0.
  int BakeSettled(double min_age_s);
  // Seconds since the map file and the raw submaps were last written by this
  // service (infinite before its first write: the first rebuild writes them).
  double SecondsSinceMapSave() const;

  const GlobalMap& map() const { return map_; }
  const ManagerStats& stats() const { return stats_; }
  // The last grid written (ok false: none yet, why says why).
  const MapGridResult& grid() const { return grid_; }
  const ManagerServiceOptions& options() const { return options_; }

 private:
  std::string RawPath() const;
  bool MoveAside(const std::string& path, const std::string& error, std::string* why);
  void UpdateCounts();
  void StampJoinedBackSubmaps();  // stats_.back_times[].joined of the current map
  bool WriteTrajectories(std::string* why);
  bool WriteGrid(std::string* why);
  bool WriteStats(std::string* why) const;

  ManagerServiceOptions options_;
  std::map<SubmapKey, Submap> received_;
  std::map<SubmapKey, std::chrono::steady_clock::time_point> received_at_;  // last version's arrival
  // SubmapFingerprint of each received_ version (merge_memo.h), hashed once
  // per version, not at every rebuild; erased when a version is replaced.
  std::map<SubmapKey, uint64_t> received_fp_;
  PlaceMergeMemo place_memo_;  // place-merge rejections, kept across rebuilds
  MergeMemo merge_memo_;       // merges of unchanged submaps, replayed
  LoopClosureState loop_state_;  // place index and keyframe searches, across rebuilds
  RevisitMemo revisit_memo_;   // revisit-fusion links of unchanged submaps
  GlobalMap map_;  // current product
  bool dirty_ = false;
  bool raw_dirty_ = false;  // received_ changed since the raw file was written
  bool map_dirty_ = false;  // map_ changed since the map file was written
  std::chrono::steady_clock::time_point map_saved_at_;  // valid once stats_.map_saves > 0
  bool unsaved_ = false;
  int written_components_ = 0;  // merged_<k>.txt files present
  MapGridResult grid_;
  LiveGrid live_grid_;  // kept between saves: new keyframes are added to it
  ManagerStats stats_;
};

// What the codec cannot check: a source of front/back, id >= 0, a usable
// camera, per keyframe as many point ids (and octaves, descriptors when
// present) as keypoints, unique keyframe ids, finite poses and points, unit
// quaternions. False with the first problem found.
bool ValidateSubmap(const Submap& s, std::string* why);

// Copy of `map` without the submaps whose key is in `drop`. Submaps that were
// in one component stay in one (their Sim(3)s already share a global frame),
// fused links to dropped submaps go.
GlobalMap CopyWithout(const GlobalMap& map, const std::vector<SubmapKey>& drop);

}  // namespace rumi
