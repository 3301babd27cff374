#!/usr/bin/env bash
# Remote back benchmark (not a test): the same generated sequence with
# tracking losses run by `rumi eval run` twice, once with the back building
# its windows here (back.mode local) and once with the windows sent over
# Cyclone DDS to a `rumi-back --remote` worker in a network namespace of its
# own, joined to this one by a veth pair (so the traffic crosses an
# interface). Prints, per run: the windows, who built each, the bytes on the
# wire each way, the wait for a claim, the build time, and the loss-to-merge
# times (metrics.json). On one machine the worker shares the CPU with the
# rest: the figures show the transport's cost, not a faster machine's gain.
# The figures of docs/results/2026-11-27-remote-back.md come from it.
#   [SYNTH_ARGS='...'] scripts/remote_back.sh [OUT=/tmp/rumi-remote] [SCENARIO=dark] [SEED=1] [SIZE=320x240] [FRAMES=600]
# (default: a 20 s QVGA room walk that goes dark at 5 s and 15 s:
# SYNTH_ARGS='--hard-start 150 --hard-period 300').
# Needs root (ip netns), build/bin/{rumi,rumi-front,rumi-back,rumi-manager},
# COLMAP and python3.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/rumi-remote}
scenario=${2:-dark}
seed=${3:-1}
size=${4:-320x240}
frames=${5:-600}
synth_args=${SYNTH_ARGS:---hard-start 150 --hard-period 300}
for b in rumi rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "remote_back: build/bin/$b missing: scripts/setup.sh" >&2; exit 1; }
done
command -v python3 > /dev/null || { echo "remote_back: python3 missing (apt install python3)" >&2; exit 1; }
[ "$(id -u)" -eq 0 ] || { echo "remote_back: needs root for ip netns" >&2; exit 1; }

mkdir -p "$out"
out=$(cd "$out" && pwd)
seq="$out/seq_${scenario}_${seed}_${size}_${frames}_$(echo "$synth_args" | tr -dc '0-9_')"
if [ ! -f "$seq/scenario.json" ]; then
  echo "remote_back: rendering $seq"
  build/bin/rumi synth "$seq" --scenario "$scenario" --seed "$seed" --size "$size" --frames "$frames" \
    $synth_args > "$out/synth.log" 2>&1
fi

# The worker's namespace: 10.231.77.2 there, 10.231.77.1 here.
ns=rumi_remote_bench
here=10.231.77.1
there=10.231.77.2
worker_pid=""
cleanup() {
  [ -n "$worker_pid" ] && kill -TERM "$worker_pid" 2>/dev/null && wait "$worker_pid" 2>/dev/null || true
  ip link del rrb_here 2>/dev/null || true
  ip netns del "$ns" 2>/dev/null || true
}
trap cleanup EXIT
cleanup
ip netns add "$ns"
ip link add rrb_here type veth peer name rrb_there
ip link set rrb_there netns "$ns"
ip addr add "$here/24" dev rrb_here
ip link set rrb_here up
ip -n "$ns" addr add "$there/24" dev rrb_there
ip -n "$ns" link set rrb_there up
ip -n "$ns" link set lo up

prefix="rumi/remote_bench_$$"
cat "$seq/camera.yaml" > "$out/local.yaml"
printf 'back: {mode: local}\n' >> "$out/local.yaml"
cat "$seq/camera.yaml" > "$out/remote.yaml"
printf 'back: {mode: remote}\ndds: {interface: %s, topic_prefix: %s}\n' "$here" "$prefix" >> "$out/remote.yaml"
cat "$seq/camera.yaml" > "$out/worker.yaml"
printf 'dds: {interface: %s, topic_prefix: %s}\n' "$there" "$prefix" >> "$out/worker.yaml"

run() {  # NAME CONFIG
  echo "remote_back: rumi eval run ($1)"
  build/bin/rumi eval run "$seq" --dataset tum --runs 1 --out "$out/$1" --overwrite --config "$2" \
    > "$out/$1.log" 2>&1 || { echo "remote_back: $1 failed; $out/$1.log" >&2; tail -20 "$out/$1.log" >&2; exit 1; }
}
run local "$out/local.yaml"
ip netns exec "$ns" build/bin/rumi-back --remote --instance bench --name worker1 --config "$out/worker.yaml" \
  > "$out/worker.log" 2>&1 &
worker_pid=$!
run remote "$out/remote.yaml"

python3 - "$out" <<'EOF'
import json, sys
out = sys.argv[1]
for name in ("local", "remote"):
    run = f"{out}/{name}/run_1"
    back = json.load(open(run + "/back/back_stats.json"))
    m = json.load(open(run + "/metrics.json"))
    print(f"== {name}: front {100 * m['front_tracking_rate_time']:.1f} %, merged "
          f"{100 * m['merged_tracking_rate_time']:.1f} %, merges {m['merges']}, ATE front "
          f"{m['front_ate_rmse']} m, merged {m['merged_ate_rmse']} m")
    print("window frames registered built_by   out_MB  in_MB  claim_s  build_s")
    for w in back["per_window"]:
        r = w.get("remote", {})
        print(f"{w['window_id']:6} {w['frames']:6} {w['registered']:10} {w['built_by']:9} "
              f"{r.get('bytes_out', 0) / 1e6:7.2f} {r.get('bytes_in', 0) / 1e6:6.3f} "
              f"{r.get('claim_wait_s', 0):8.2f} {w['seconds']['total']:8.1f}")
    print(f"losses {m.get('losses')}, merged {m.get('losses_merged')}; loss to merge p50/p95/max "
          f"{m.get('loss_to_merge_p50_s')} / {m.get('loss_to_merge_p95_s')} / {m.get('loss_to_merge_max_s')} s")
EOF
