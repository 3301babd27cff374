#pragma once
// status.json in rumid's state folder: written by rumid every
// daemon.status_interval_s, read by `rumi status`. Keys:
//   instance, pid, state (starting|running|stopping|stopped|failed), started,
//   updated (ISO 8601), uptime_s, config, state_dir, source, summary,
//   children [{name, pid, state, uptime_s, restarts, ready, heartbeat_age_s, last_exit,
//              rss_mib, private_mib, shared_mib, fds}],
//   front {state, frames, tracked, skipped, submap, windows, windows_sent, windows_dropped, source, ...},
//   back {queue, received, built, failed, dropped, building {window, frames, stage, elapsed_s}},
//   manager {state, submaps_front, submaps_back, components, merges, rebuilds, last_rebuild_s, last_save, ...},
//   rings [{name, pushed, popped, dropped, producer_alive, consumer_alive}]
#include <nlohmann/json.hpp>
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

// Reads <state_dir>/status.json; false with *why (no rumid ran there, unreadable).
bool ReadDaemonStatus(const std::string& state_dir, nlohmann::json* status, std::string* why);

}  // namespace rumi
