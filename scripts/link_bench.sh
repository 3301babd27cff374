#!/usr/bin/env bash
# Robot link benchmark (not a test): `rumi robot-sim` streams a generated
# sequence over UDP loopback to rumid (source.kind: link) under several link
# conditions, for several seeds, and the same sequence is also run from disk
# (`rumi eval run`). Prints one row per run: frames sent / complete /
# dropped, fragments recovered by NACK, latency p50/p95/max, the clock
# offset's error, the robot's fail-safe stops, and the merged tracking rate
# and ATE of the session against the disk run's.
# The figures of docs/results/2026-11-27-robot-link-spread.md come from it.
#   scripts/link_bench.sh [OUT=/tmp/rumi-link] [SEEDS="1 2 3"] [SCENARIO=drop] [FRAMES=300]
# CONDITIONS (one per line: name, then robot-sim arguments) overrides the default set.
# Needs build/bin/{rumi,rumid,rumi-front,rumi-back,rumi-manager}, COLMAP and python3.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rumi-link}
seeds=${2:-1 2 3}
scenario=${3:-drop}
frames=${4:-300}
conditions=${CONDITIONS:-"loss10 --loss 0.1 --latency-ms 50 --jitter-ms 30
burst10 --loss 0.1 --burst 4 --latency-ms 50 --jitter-ms 30
cap4000 --loss 0.1 --latency-ms 50 --jitter-ms 30 --bandwidth-kbps 4000
cap2500 --loss 0.1 --latency-ms 50 --jitter-ms 30 --bandwidth-kbps 2500"}
for b in rumi rumid rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "link_bench: build/bin/$b missing: scripts/setup.sh" >&2; exit 1; }
done
command -v python3 > /dev/null || { echo "link_bench: python3 missing (apt install python3)" >&2; exit 1; }
mkdir -p "$out"
out=$(cd "$out" && pwd)
bin=$(pwd)/build/bin

# One field of a JSON file, by a Python expression on `j`.
field() { python3 -c "import json,sys; j=json.load(open(sys.argv[1])); print($2)" "$1" 2>/dev/null || echo "?"; }

printf '%-8s %4s %5s %8s %7s %9s %17s %9s %8s %15s %15s\n' condition seed sent complete dropped recovered \
  "latency p50/p95/max" "clock err" failsafe "link rate/ATE" "disk rate/ATE"
for seed in $seeds; do
  seq="$out/seq_${scenario}_${seed}_${frames}"
  if [ ! -f "$seq/scenario.json" ]; then
    "$bin/rumi" synth "$seq" --scenario "$scenario" --seed "$seed" --size 320x240 --frames "$frames" \
      > "$out/synth_$seed.log" 2>&1
  fi
  disk="$out/disk_$seed"
  if [ ! -f "$disk/run_1/metrics.json" ]; then
    "$bin/rumi" eval run "$seq" --dataset tum --config "$seq/camera.yaml" --runs 1 --out "$disk" --overwrite \
      > "$out/disk_$seed.log" 2>&1 || true
  fi
  disk_rate=$(field "$disk/run_1/metrics.json" "'%.1f%%/%.3fm' % (100*j['merged_tracking_rate_time'], j['merged_ate_rmse'])")
  while IFS= read -r line; do
    [ -n "$line" ] || continue
    name=${line%% *}
    args=${line#* }
    run="$out/${name}_$seed"
    rm -rf "$run"
    mkdir -p "$run"
    port=$((21000 + RANDOM % 20000))
    "$bin/rumi" link keygen --out "$run/robot.key" > /dev/null
    {
      cat "$seq/camera.yaml"
      printf 'log_level: info\nsource:\n  kind: link\n  link: {bind: "127.0.0.1:%s", end_after_silence_s: 3, key_file: %s}\n' "$port" "$run/robot.key"
      printf 'daemon:\n  child_output: files\n  state_dir: %s/state\n' "$run"
    } > "$run/rumid.yaml"
    "$bin/rumid" --config "$run/rumid.yaml" --instance "lb$$_$seed" > "$run/rumid.log" 2>&1 &
    rumid_pid=$!
    sleep 2
    # shellcheck disable=SC2086
    "$bin/rumi" robot-sim "$seq" --ground "127.0.0.1:$port" --seed "$seed" --clock-offset-ms 4321.5 --drift-ppm 20 \
      --stats-out "$run/sim.json" --groundtruth-out "$run/gt.txt" --key "$run/robot.key" $args > "$run/sim.log" 2>&1 || true
    for _ in $(seq 1 1200); do kill -0 "$rumid_pid" 2>/dev/null || break; sleep 0.5; done
    kill -TERM "$rumid_pid" 2>/dev/null || true
    wait "$rumid_pid" 2>/dev/null || true
    link="$run/state/front/front_stats.json"
    "$bin/rumi" eval ate "$run/state/merged.txt" "$run/gt.txt" --frames "$run/gt.txt" --json > "$run/ate.json" 2>/dev/null || true
    printf '%-8s %4s %5s %8s %7s %9s %17s %9s %8s %15s %15s\n' "$name" "$seed" \
      "$(field "$run/sim.json" "j['frames_sent']")" \
      "$(field "$link" "j['link']['frames_complete']")" \
      "$(field "$link" "j['link']['frames_dropped']")" \
      "$(field "$link" "j['link']['fragments_recovered']")" \
      "$(field "$link" "'%.0f/%.0f/%.0f' % (j['link']['latency_ms']['p50'], j['link']['latency_ms']['p95'], j['link']['latency_ms']['max'])")" \
      "$(python3 -c "import json; a=json.load(open('$link'))['link']['clock']; b=json.load(open('$run/sim.json')); print('%.2f ms' % abs(a['offset_ms']-b['clock_offset_ms']))" 2>/dev/null || echo "?")" \
      "$(field "$run/sim.json" "j['failsafe_stops']")" \
      "$(field "$run/ate.json" "'%.1f%%/%.3fm' % (100*j['tracking']['covered_rate'], j['ate_translation']['rmse'])")" \
      "$disk_rate"
  done <<< "$conditions"
done
