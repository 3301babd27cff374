#!/usr/bin/env bash
# Memory soak of the live daemon (a benchmark, not a test): rumid replays a
# 60 s QVGA room walk (`rumi synth`, smooth seed 2) in a loop as its camera for
# MINUTES (each pass ends in a jump back to the start: a loss, a new submap, a
# back window), with the default daemon config otherwise. Every 30 s the RSS
# of rumi-front, rumi-back, rumi-manager and COLMAP goes to OUT/rss.tsv; at
# the end the medians per 2-minute window are printed. The figures of
# docs/results/2026-11-25-front-split-and-soak.md come from it.
#   scripts/soak_rumid.sh [MINUTES=70] [OUT=/tmp/rumi-soak]
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-70}
out=${2:-/tmp/rumi-soak}
for b in rumi rumid rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "soak: build/bin/$b missing: scripts/setup.sh" >&2; exit 1; }
done
command -v python3 > /dev/null || { echo "soak: python3 missing (apt install python3)" >&2; exit 1; }
mkdir -p "$out"
seq="$out/seq"
[ -f "$seq/scenario.json" ] ||
  build/bin/rumi synth "$seq" --scenario smooth --seed 2 --frames 1800 --size 320x240 --supersample 1 > "$out/synth.log" 2>&1
# The bundled daemon config with the sequence, looped, as its source.
python3 - configs/daemon.yaml "$out/soak.yaml" "$seq" <<'PY'
import re, sys
src, dst, seq = sys.argv[1:]
text = open(src).read()
source = f"source:\n  kind: dataset\n  dataset: tum\n  path: {seq}\n  calibration: {seq}/camera.yaml\n  loop: true\n"
text = re.sub(r"^source:\n(?:[ #].*\n|\n)*", source, text, flags=re.M)
open(dst, "w").write(text.replace("child_output: journal", "child_output: files"))
PY
build/bin/rumi config check "$out/soak.yaml"
rm -rf "$out/state"
build/bin/rumid --config "$out/soak.yaml" --state-dir "$out/state" --bin-dir build/bin > "$out/rumid.log" 2>&1 &
pid=$!
trap 'kill -TERM $pid 2>/dev/null || true' EXIT
echo -e "elapsed_s\tfront_kib\tback_kib\tmanager_kib\tcolmap_kib" > "$out/rss.tsv"
start=$(date +%s)
while kill -0 "$pid" 2> /dev/null && [ $(( $(date +%s) - start )) -lt $(( minutes * 60 )) ]; do
  row=$(( $(date +%s) - start ))
  for p in rumi-front rumi-back rumi-manager colmap; do
    row="$row\t$({ ps -C "$p" -o rss= 2> /dev/null || true; } | awk '{s += $1} END {print s + 0}')"
  done
  echo -e "$row" >> "$out/rss.tsv"
  sleep 30
done
kill -TERM "$pid" 2> /dev/null || true
wait "$pid" || true
trap - EXIT
python3 - "$out/rss.tsv" <<'PY'
import statistics, sys
rows = [list(map(int, l.split("\t"))) for l in open(sys.argv[1]).read().splitlines()[1:] if l.strip()]
print("window_s\tfront_MiB (median min max)\tback_MiB\tmanager_MiB")
for a in range(0, rows[-1][0] + 1, 120):
    w = [r for r in rows if a <= r[0] < a + 120 and r[1] > 0]
    if not w:
        continue
    f = [r[1] / 1024 for r in w]
    print(f"{a}-{a + 120}\t{statistics.median(f):.0f} {min(f):.0f} {max(f):.0f}\t"
          f"{statistics.median(r[2] / 1024 for r in w):.0f}\t{statistics.median(r[3] / 1024 for r in w):.0f}")
PY
