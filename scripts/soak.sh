#!/usr/bin/env bash
# Soak benchmark (not a test): rumid on a looped generated sequence with a
# loss in every loop, for MINUTES (default 35), sampled every 30 s with
# `rumi status --csv`: RSS (and its private and shared-ring parts) and open
# fds of rumid and each child, restarts,
# submaps, merges, rebuild time, back windows. Prints the samples, then per
# process RSS and fds after warm-up (first sample after 5 min) against the
# end, the largest rebuild time, merges / windows per hour, and the median
# RSS per 2-minute window.
#   scripts/soak.sh [MINUTES] [OUT] [SEQUENCE]    (OUT default /tmp/rumi-soak; env SOAK_YAML)
# SEQUENCE: `dark` (default: 300 frames 640x480 `dark` seed 2 with its
# odometry, sequential back matcher) or `walk` (a 60 s QVGA smooth walk,
# seed 2, under the bundled configs/daemon.yaml: the memory soak of
# docs/results/2026-11-25-front-split-and-soak.md).
# Needs the executables (scripts/setup.sh rumid rumi rumi-front rumi-back rumi-manager).
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-35}
out=${2:-/tmp/rumi-soak}
sequence=${3:-dark}
seq="$out/$sequence"
state="$out/state"
mkdir -p "$out"
for b in rumid rumi rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "soak: build/bin/$b missing: scripts/setup.sh rumid rumi rumi-front rumi-back rumi-manager" >&2; exit 1; }
done
cfg="$out/soak.yaml"
case "$sequence" in
  dark)
    [ -f "$seq/scenario.json" ] ||
      build/bin/rumi synth "$seq" --scenario dark --seed 2 --frames 300 --dark-gain 0.02 > "$out/synth.log" 2>&1
    {
      cat "$seq/camera.yaml"
      echo "log_level: info"
      echo "source: {kind: dataset, dataset: tum, path: $seq, odometry: $seq/odometry.txt, loop: true}"
      echo "back: {matcher: sequential, max_num_features: 1024}"
      echo "daemon: {child_output: files, state_dir: $state}"
    } > "$cfg"
    ;;
  walk)
    command -v python3 > /dev/null || { echo "soak: python3 missing (apt install python3)" >&2; exit 1; }
    [ -f "$seq/scenario.json" ] ||
      build/bin/rumi synth "$seq" --scenario smooth --seed 2 --frames 1800 --size 320x240 --supersample 1 \
        > "$out/synth.log" 2>&1
    # The bundled daemon config with the walk, looped, as its source.
    python3 - configs/daemon.yaml "$cfg" "$seq" "$state" <<'PY'
import re, sys
src, dst, seq, state = sys.argv[1:]
text = open(src).read()
source = f"source:\n  kind: dataset\n  dataset: tum\n  path: {seq}\n  calibration: {seq}/camera.yaml\n  loop: true\n"
text = re.sub(r"^source:\n(?:[ #].*\n|\n)*", source, text, flags=re.M)
text = re.sub(r"^daemon:\n", f"daemon:\n  state_dir: {state}\n", text, count=1, flags=re.M)
open(dst, "w").write(text.replace("child_output: journal", "child_output: files"))
PY
    ;;
  *)
    echo "soak: unknown sequence '$sequence' (dark or walk)" >&2
    exit 2
    ;;
esac
# SOAK_YAML: more config (sections the config does not have yet), e.g.
# SOAK_YAML='manager: {place_retry_growth: 0}'.
if [ -n "${SOAK_YAML:-}" ]; then printf '%s\n' "$SOAK_YAML" >> "$cfg"; fi
build/bin/rumi config check "$cfg" > /dev/null
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
    printf "%-14s %12s %12s %14s %14s %10s %10s\n", "process", "RSS warm MiB", "RSS end MiB", "private warm", "private end", "fds warm", "fds end"
    split("rumid front back manager", p, " ")
    for (k = 1; k <= 4; ++k) {
      pw = (p[k] "_private_mib" in col) ? a[col[p[k] "_private_mib"]] : "-"
      pz = (p[k] "_private_mib" in col) ? z[col[p[k] "_private_mib"]] : "-"
      printf "%-14s %12s %12s %14s %14s %10s %10s\n", p[k], a[col[p[k] "_rss_mib"]], z[col[p[k] "_rss_mib"]], pw, pz, a[col[p[k] "_fds"]], z[col[p[k] "_fds"]]
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
python3 - "$csv" <<'PY' || true
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
procs = ["front", "back", "manager"]
# RSS, then its private part (heap, stacks) and the touched pages of the
# shared rings (bounded by the rings' sizes), per process.
cols = [f"{p}_{k}_mib" for p in procs for k in ("rss", "private", "shared") if f"{p}_{k}_mib" in (rows[0] if rows else {})]
print("window_s\t" + "\t".join(cols) + "\t(median per 2-minute window)")
for a in range(0, int(float(rows[-1]["uptime_s"])) + 1, 120) if rows else []:
    w = [r for r in rows if a <= float(r["uptime_s"]) < a + 120]
    if w:
        print(f"{a}-{a + 120}\t" + "\t".join(
            f"{statistics.median(float(r[c]) for r in w if r[c]):.0f}" if any(r[c] for r in w) else "-" for c in cols))
PY
