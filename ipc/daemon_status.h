#pragma once
// status.json in rumid's state folder: written by rumid every
// daemon.status_interval_s, read by `rumi status`. Keys:
//   instance, pid, pid_start_ticks, state (starting|running|stopping|stopped|failed), started,
//   updated (ISO 8601), updated_unix_s, status_interval_s, uptime_s, config, state_dir, source, summary,
//   children [{name, pid, state, uptime_s, restarts, ready, heartbeat_age_s, last_exit,
//              rss_mib, private_mib, shared_mib, fds}],
//   front {state, frames, tracked, skipped, submap, windows, windows_sent, windows_dropped, source, ...},
//   back {queue, received, built, failed, dropped, building {window, frames, stage, elapsed_s}},
//   manager {state, submaps_front, submaps_back, components, merges, rebuilds, last_rebuild_s, last_save, ...},
//   rings [{name, pushed, popped, dropped, producer_alive, consumer_alive}]
#include <nlohmann/json.hpp>

#include <cmath>
#include <string>

namespace rumi {

// One line for systemd's STATUS=: source, tracking state, submaps, merges,
// back queue.
std::string DaemonSummary(const nlohmann::json& status);

// The human table of `rumi status`. `alive`: rumid's pid still runs.
std::string FormatDaemonStatus(const nlohmann::json& status, bool alive);

// One CSV line (with a header line before it when `header`): the soak
// benchmark's sample (scripts/soak.sh): uptime, RSS and fds of rumid and each
// child, restarts, frames, submaps, merges, rebuilds, last rebuild time,
// windows built / failed / dropped, then each child's private and
// shared-segment RSS (process_info.h: only the private part is the
// process's own growth).
std::string DaemonStatusCsv(const nlohmann::json& status, bool header);

// Whether the rumid that wrote `status` still runs (its pid, and the same
// process: its start time, when the file has it) and still writes it: stale
// when the last write is older than 5 status intervals (at least 10 s), a
// rumid stopped or hung.
struct DaemonLiveness {
  bool alive = false;
  bool stale = false;
  double age_s = NAN;  // since the last write (NaN: the file does not say)
};
DaemonLiveness CheckDaemonLiveness(const nlohmann::json& status, double now_unix_s);

// Reads <state_dir>/status.json; false with *why (no rumid ran there, unreadable).
bool ReadDaemonStatus(const std::string& state_dir, nlohmann::json* status, std::string* why);

}  // namespace rumi
