#!/usr/bin/env bash
# Rebuilds the windows a run sent to the back, as window folders that
# `rumi-back --window-dir` reads (the back's benchmark input: docs/back.md).
#
#   scripts/export_windows.sh RUNDIR SEQUENCE OUT
#
# RUNDIR: a `rumi eval run` run folder (its front_samples.txt: t set window).
# SEQUENCE: the dataset folder it ran on (rgb.txt: t path). Writes
# OUT/window_<id>/rgb.txt ("t absolute-path set") for every window; the
# images stay where they are. Frames are matched by time within 0.1 ms.
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 RUNDIR SEQUENCE OUT" >&2; exit 2; }
run="$1"; seq="$(cd "$2" && pwd)"; out="$3"
[ -f "$run/front_samples.txt" ] || { echo "$run/front_samples.txt: missing" >&2; exit 1; }
[ -f "$seq/rgb.txt" ] || { echo "$seq/rgb.txt: missing" >&2; exit 1; }
mkdir -p "$out"
awk -v seq="$seq" -v out="$out" '
  FNR == NR { if ($0 !~ /^#/ && NF >= 2) { t[++n] = $1 + 0; p[n] = ($2 ~ /^\//) ? $2 : seq "/" $2 }; next }
  $0 ~ /^#/ || NF < 3 { next }
  {
    want = $1 + 0; best = 0
    # rgb.txt is in time order: a binary search for the nearest frame.
    lo = 1; hi = n
    while (lo < hi) { mid = int((lo + hi) / 2); if (t[mid] < want) lo = mid + 1; else hi = mid }
    for (k = lo - 1; k <= lo; ++k) if (k >= 1 && k <= n && (best == 0 || abs(t[k] - want) < abs(t[best] - want))) best = k
    if (best == 0 || abs(t[best] - want) > 1e-4) { printf "%s: no image at t=%s\n", FILENAME, $1 > "/dev/stderr"; bad = 1; next }
    dir = out "/window_" $3
    if (!(dir in made)) { system("mkdir -p \"" dir "\""); made[dir] = 1; print "# t path set" > (dir "/rgb.txt") }
    print $1, p[best], $2 >> (dir "/rgb.txt")
  }
  function abs(x) { return x < 0 ? -x : x }
  END { exit bad }
' "$seq/rgb.txt" "$run/front_samples.txt"
ls -d "$out"/window_* 2>/dev/null
