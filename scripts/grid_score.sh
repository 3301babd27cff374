#!/usr/bin/env bash
# The occupancy grid scored against the true floor plans of generated
# sequences (issue #20): rooms (`smooth`, hand-held camera at 1.35 m, band
# 0.05-2.0 m) and corridors (`corridor`, camera at 0.45 m, band 0.05-1.2 m
# under their 1.5 m ceiling), each with its odometry; one row per sequence
# and cell size. The corridors lose track in their plain zone and are joined
# by a merge; `corridorN_noloss` is the same corridor with that zone
# textured (no loss), to compare the grids with and without the loss.
# Sequences and runs are kept in OUT and reused.
#
#   scripts/grid_score.sh [OUT] [GRID_YAML] [FRAMES]
#   scripts/grid_score.sh /tmp/gs "slice_m: 0"        # the flat grid, for comparison
#
# GRID_YAML: extra keys of the `grid:` section (flow style), e.g. "slice_m: 0".
set -euo pipefail
OUT=${1:-/tmp/rumi-grid-score}
EXTRA=${2:-}
FRAMES=${3:-300}
BIN=${RUMI_BIN_DIR:-$(cd "$(dirname "$0")/.." && pwd)/build/bin}
RUMI="$BIN/rumi"
mkdir -p "$OUT"
printf '%-17s %5s %8s %8s %8s %6s %6s %6s %6s\n' sequence cell occ_iou free_iou coverage found as_free unseen false
for spec in "smooth 1 2.0" "smooth 2 2.0" "smooth 3 2.0" "corridor 1 1.2" "corridor 2 1.2" \
  "corridor 1 1.2 _noloss --weak-amplitude 0.3" "corridor 2 1.2 _noloss --weak-amplitude 0.3"; do
  read -r scenario seed band suffix synth_args <<<"$spec"
  name=$scenario$seed${suffix:-}
  synth_args=${synth_args:-}
  seq="$OUT/$name"
  if [ ! -f "$seq/rgb.txt" ]; then
    # shellcheck disable=SC2086
    "$RUMI" synth "$seq" --scenario "$scenario" --seed "$seed" --frames "$FRAMES" --grid-robot-height "$band" \
      $synth_args >"$OUT/synth_$name.log" 2>&1
  fi
  run="$OUT/run_$name"
  if [ ! -f "$run/run_1/map.rumi" ]; then
    { cat "$seq/camera.yaml"; printf '\ngrid: {robot_height_m: %s}\n' "$band"; } >"$OUT/config_$name.yaml"
    "$RUMI" eval run "$seq" --dataset tum --config "$OUT/config_$name.yaml" --odometry "$seq/odometry.txt" \
      --out "$run" >"$OUT/eval_$name.log" 2>&1
  fi
  for cell in 0.05 0.1; do
    truth="$OUT/truth_${name}_$cell"
    if [ ! -f "$truth/floorplan.yaml" ]; then
      # shellcheck disable=SC2086
      "$RUMI" synth "$truth" --scenario "$scenario" --seed "$seed" --frames "$FRAMES" --grid-robot-height "$band" \
        --grid-resolution "$cell" --floorplan-only $synth_args >/dev/null 2>&1
      cp "$seq/groundtruth.txt" "$truth/"
    fi
    grid="$OUT/grid_${name}_$cell"
    printf 'grid: {robot_height_m: %s, resolution_m: %s%s}\n' "$band" "$cell" "${EXTRA:+, $EXTRA}" >"$OUT/grid.yaml"
    "$RUMI" grid "$run/run_1" --config "$OUT/grid.yaml" --out "$grid" >/dev/null
    "$RUMI" eval grid "$grid" "$truth" --json --diff "$grid/comparison.png" | python3 -c '
import json, sys
d = json.load(sys.stdin)
print("%-17s %5s %8.3f %8.3f %7.1f%% %6d %6d %6d %6d" % (sys.argv[1], sys.argv[2], d["occupied_iou"], d["free_iou"],
      100 * d["coverage"], d["walls_found"], d["walls_as_free"], d["walls_unknown"], d["false_walls"]))' "$name" "$cell"
  done
done
