#!/usr/bin/env bash
# Soak benchmark (not a test): rumid on a looped generated sequence with a
# loss in every loop, for MINUTES (default 35), sampled every 30 s with
# `rumi status --csv`: RSS and open fds of rumid and each child, restarts,
# submaps, merges, rebuild time, back windows. Prints the samples, then per
# process RSS and fds after warm-up (first sample after 5 min) against the
# end, the largest rebuild time, and merges / windows per hour.
#   scripts/soak.sh [MINUTES] [OUT]          (OUT default /tmp/rumi-soak)
# Needs the executables (scripts/setup.sh rumid rumi rumi-front rumi-back rumi-manager).
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-35}
out=${2:-/tmp/rumi-soak}
seq="$out/dark"
state="$out/state"
mkdir -p "$out"
for b in rumid rumi rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "soak: build/bin/$b missing: scripts/setup.sh rumid rumi rumi-front rumi-back rumi-manager" >&2; exit 1; }
done
if [ ! -f "$seq/scenario.json" ]; then
  build/bin/rumi synth "$seq" --scenario dark --seed 2 --frames 300 --dark-gain 0.02 > "$out/synth.log" 2>&1
fi
cfg="$out/soak.yaml"
{
  cat "$seq/camera.yaml"
  echo "log_level: info"
  echo "source: {kind: dataset, dataset: tum, path: $seq, odometry: $seq/odometry.txt, loop: true}"
  echo "back: {matcher: sequential, max_num_features: 1024}"
  echo "daemon: {child_output: files, state_dir: $state}"
} > "$cfg"
rm -rf "$state"
build/bin/rumid --config "$cfg" --instance soak > "$out/rumid.log" 2>&1 &
rumid=$!
trap 'kill -TERM $rumid 2>/dev/null || true; wait $rumid 2>/dev/null || true' EXIT
csv="$out/soak.csv"
: > "$csv"
end=$(( $(date +%s) + minutes * 60 ))
while [ "$(date +%s)" -lt "$end" ]; do
  sleep 30
  kill -0 "$rumid" 2>/dev/null || { echo "soak: rumid exited early; $out/rumid.log" >&2; exit 1; }
  if [ -s "$csv" ]; then
    build/bin/rumi status --csv --state-dir "$state" | tail -n 1 >> "$csv"
  else
    build/bin/rumi status --csv --state-dir "$state" >> "$csv"
  fi
  tail -n 1 "$csv"
done
kill -TERM "$rumid"
t0=$(date +%s%N)
wait "$rumid" && rc=0 || rc=$?
stop_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
trap - EXIT
echo
echo "soak: $minutes min, rumid exit $rc ${stop_ms} ms after SIGTERM; samples in $csv"
awk -F, '
  NR == 1 { for (i = 1; i <= NF; ++i) col[$i] = i; next }
  { rows[NR] = $0; n = NR }
  END {
    # Warm-up: the first sample at or after 300 s of uptime.
    w = 0
    for (r = 2; r <= n; ++r) { split(rows[r], f, ","); if (f[col["uptime_s"]] >= 300) { w = r; break } }
    if (w == 0) w = 2
    split(rows[w], a, ","); split(rows[n], z, ",")
    hours = (z[col["uptime_s"]] - a[col["uptime_s"]]) / 3600
    printf "%-14s %12s %12s %10s %10s\n", "process", "RSS warm MiB", "RSS end MiB", "fds warm", "fds end"
    split("rumid front back manager", p, " ")
    for (k = 1; k <= 4; ++k) {
      printf "%-14s %12s %12s %10s %10s\n", p[k], a[col[p[k] "_rss_mib"]], z[col[p[k] "_rss_mib"]], a[col[p[k] "_fds"]], z[col[p[k] "_fds"]]
    }
    max_rebuild = 0
    for (r = 2; r <= n; ++r) { split(rows[r], f, ","); if (f[col["last_rebuild_s"]] + 0 > max_rebuild) max_rebuild = f[col["last_rebuild_s"]] + 0 }
    printf "from %.0f s to %.0f s: merges %d -> %d, rebuilds %d -> %d, windows built %d -> %d (dropped %d), frames %d -> %d\n",
      a[col["uptime_s"]], z[col["uptime_s"]], a[col["merges"]], z[col["merges"]], a[col["rebuilds"]], z[col["rebuilds"]],
      a[col["windows_built"]], z[col["windows_built"]], z[col["windows_dropped"]], a[col["frames"]], z[col["frames"]]
    if (hours > 0)
      printf "per hour: %.0f merges (net), %.0f rebuilds, %.1f windows built; largest last-rebuild time %.2f s; restarts front/back/manager %s/%s/%s\n",
        (z[col["merges"]] - a[col["merges"]]) / hours, (z[col["rebuilds"]] - a[col["rebuilds"]]) / hours,
        (z[col["windows_built"]] - a[col["windows_built"]]) / hours, max_rebuild,
        z[col["front_restarts"]], z[col["back_restarts"]], z[col["manager_restarts"]]
  }' "$csv"
