#!/usr/bin/env bash
# The front alone over every generated scenario (benchmark, not a test):
# rumi-front --sync --no-pace on `rumi synth` sequences, one run at a time,
# printing the largest submap's frame rate and ATE per run.
#   scripts/front_scenarios.sh OUT [SEEDS] [SIZES] [FRONT_YAML]
# SEEDS "1 2 3", SIZES "320x240 640x480"; FRONT_YAML is appended to each
# sequence's camera.yaml (e.g. $'front:\n  init_backfill: false').
# Sequences are generated once under OUT/seq and reused.
set -euo pipefail
out=${1:?OUT}
seeds=${2:-1 2 3}
sizes=${3:-320x240 640x480}
extra=${4:-}
bin=${RUMI_BIN:-$(cd "$(dirname "$0")/.." && pwd)/build/bin}
frames=${FRAMES:-300}
mkdir -p "$out/seq" "$out/run"
printf '%-9s %4s %-8s %6s %9s %10s\n' scenario seed size poses frame_rate ate_m
for scenario in smooth blur dark drop weak kidnap corridor; do
  for seed in $seeds; do
    for size in $sizes; do
      seq="$out/seq/${scenario}_${seed}_$size"
      [ -f "$seq/rgb.txt" ] || "$bin/rumi" synth "$seq" --scenario "$scenario" --frames "$frames" --size "$size" \
        --seed "$seed" > /dev/null 2>&1
      cfg="$out/run/${scenario}_${seed}_$size.yaml"
      { cat "$seq/camera.yaml"; printf '%s\n' "$extra"; } > "$cfg"
      run="$out/run/${scenario}_${seed}_$size"
      line=$("$bin/rumi-front" --dataset tum "$seq" --config "$cfg" --sync --no-pace --out "$run" 2>&1 |
        grep -o 'largest submap.*' | tail -1 || true)
      poses=$(sed -n 's/.*: \([0-9]*\) poses.*/\1/p' <<< "$line")
      rate=$(sed -n 's/.*frame rate \([0-9.]*\) %.*/\1/p' <<< "$line")
      ate=$(sed -n 's/.*rmse \([0-9.e-]*\) m.*/\1/p' <<< "$line")
      printf '%-9s %4s %-8s %6s %9s %10s\n' "$scenario" "$seed" "$size" "${poses:--}" "${rate:--}" "${ate:--}"
    done
  done
done
