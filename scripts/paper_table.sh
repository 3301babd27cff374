#!/usr/bin/env bash
# Reproduces the RUMI-SLAM paper's Table IV: `rumi eval run` on every
# sequence that scripts/download_datasets.sh fetched, N runs each, then
# `rumi eval table` over all of them (markdown on stdout, CSV in OUT/table.csv).
#
#   scripts/paper_table.sh DATASETS OUT [RUNS]
#
# Environment: RUMI (the rumi executable; default: rumi on PATH, else
# build/bin/rumi), RATE (replay rate, default 1.0: the recorded rate, as in
# the paper), TIMEOUT (seconds per run, default: rumi's), EXTRA (more
# `rumi eval run` options, e.g. "--no-back").
# A sequence that fails is reported and skipped; the table lists the others.
set -uo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(dirname "$here")"

[ $# -ge 2 ] || { echo "usage: $0 DATASETS OUT [RUNS]" >&2; exit 2; }
data="$1"
out="$2"
runs="${3:-3}"
rate="${RATE:-1.0}"
configs="$repo/configs"

if [ -z "${RUMI:-}" ]; then
  if command -v rumi >/dev/null 2>&1; then RUMI="$(command -v rumi)"; else RUMI="$repo/build/bin/rumi"; fi
fi
[ -x "$RUMI" ] || { echo "paper_table: rumi not found at $RUMI (set RUMI=...)" >&2; exit 1; }
[ -d "$data" ] || { echo "paper_table: no dataset folder $data" >&2; exit 1; }
mkdir -p "$out"

done_dirs=()
failed=()

# run NAME KIND PATH CONFIG
run() {
  local name="$1" kind="$2" path="$3" config="$4"
  if [ ! -d "$path" ]; then
    echo "paper_table: $name not downloaded ($path), skipped" >&2
    return
  fi
  echo "=== $name ($kind, $(basename "$config"), $runs runs)"
  local args=(eval run "$path" --dataset "$kind" --config "$config" --runs "$runs" --rate "$rate"
              --out "$out/$name" --sequence "$name")
  [ -n "${TIMEOUT:-}" ] && args+=(--timeout "$TIMEOUT")
  # shellcheck disable=SC2206
  [ -n "${EXTRA:-}" ] && args+=(${EXTRA})
  if "$RUMI" "${args[@]}"; then
    done_dirs+=("$out/$name")
  else
    failed+=("$name")
  fi
}

tum="$data/tum/rgbd_dataset_freiburg"
run fr1_room                  tum "${tum}1_room"                  "$configs/tum_fr1.yaml"
run fr1_teddy                 tum "${tum}1_teddy"                 "$configs/tum_fr1.yaml"
run fr2_desk                  tum "${tum}2_desk"                  "$configs/tum_fr2.yaml"
run fr2_360_kidnap            tum "${tum}2_360_kidnap"            "$configs/tum_fr2.yaml"
run fr2_pioneer_slam          tum "${tum}2_pioneer_slam"          "$configs/tum_fr2.yaml"
run fr2_pioneer_slam2         tum "${tum}2_pioneer_slam2"         "$configs/tum_fr2.yaml"
run fr2_pioneer_slam3         tum "${tum}2_pioneer_slam3"         "$configs/tum_fr2.yaml"
run fr3_long_office_household tum "${tum}3_long_office_household" "$configs/tum_fr3.yaml"
run fr3_teddy                 tum "${tum}3_teddy"                 "$configs/tum_fr3.yaml"

run V1_02 euroc "$data/euroc/V1_02_medium"    "$configs/euroc.yaml"
run V1_03 euroc "$data/euroc/V1_03_difficult" "$configs/euroc.yaml"
run V2_02 euroc "$data/euroc/V2_02_medium"    "$configs/euroc.yaml"
run V2_03 euroc "$data/euroc/V2_03_difficult" "$configs/euroc.yaml"

run lr_kt0     icl "$data/icl/living_room_traj0_frei_png" "$configs/icl_nuim.yaml"
run lr_kt2     icl "$data/icl/living_room_traj2_frei_png" "$configs/icl_nuim.yaml"
run office_kt0 icl "$data/icl/traj0_frei_png"             "$configs/icl_nuim.yaml"
run office_kt2 icl "$data/icl/traj2_frei_png"             "$configs/icl_nuim.yaml"
run office_kt3 icl "$data/icl/traj3_frei_png"             "$configs/icl_nuim.yaml"

echo
if [ ${#failed[@]} -gt 0 ]; then
  echo "paper_table: failed: ${failed[*]} (see their run_*/*.log)" >&2
fi
if [ ${#done_dirs[@]} -eq 0 ]; then
  echo "paper_table: no sequence finished" >&2
  exit 1
fi
"$RUMI" eval table "${done_dirs[@]}" --csv "$out/table.csv"
[ ${#failed[@]} -eq 0 ]
