#!/usr/bin/env bash
# Back stress benchmark (not a test): a generated room walk that loses track
# every PERIOD seconds (a dark dip) for MINUTES, replayed live by
# `rumi eval run` (front at the recorded rate, back and manager as they
# are). While it runs, the RSS of the three processes and of COLMAP is
# sampled every 10 s. Then prints: the windows the back received, joined,
# dropped and built; the queue over time (back_stats.json queue_history,
# per minute: max waiting windows); the wait and build time per window; the
# loss-to-merge times (metrics.json); RSS per process at the start and the
# end. The figures of docs/results/2026-11-24-back-queue.md come from it.
#   scripts/stress_back.sh [MINUTES=10] [PERIOD_S=10] [OUT=/tmp/rumi-stress] [SIZE=320x240]
# Needs build/bin/{rumi,rumi-front,rumi-back,rumi-manager}, COLMAP and python3.
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-10}
period=${2:-10}
out=${3:-/tmp/rumi-stress}
size=${4:-320x240}
for b in rumi rumi-front rumi-back rumi-manager; do
  [ -x "build/bin/$b" ] || { echo "stress: build/bin/$b missing: scripts/setup.sh" >&2; exit 1; }
done
command -v python3 > /dev/null || { echo "stress: python3 missing (apt install python3)" >&2; exit 1; }
fps=30
frames=$(( minutes * 60 * fps ))
seq="$out/seq_${minutes}min_${period}s_${size}"
mkdir -p "$out"
if [ ! -f "$seq/scenario.json" ]; then
  echo "stress: rendering $frames frames to $seq (a few minutes per minute of sequence)"
  build/bin/rumi synth "$seq" --scenario dark --seed 1 --frames "$frames" --size "$size" \
    --hard-start $(( 5 * fps )) --hard-period $(( period * fps )) > "$out/synth.log" 2>&1
fi
run="$out/run"
rss="$out/rss.tsv"
echo -e "elapsed_s\tprocess\trss_kib" > "$rss"
build/bin/rumi eval run "$seq" --dataset tum --runs 1 --out "$run" --overwrite --config "$seq/camera.yaml" \
  > "$out/eval.log" 2>&1 &
eval_pid=$!
trap 'kill -TERM $eval_pid 2>/dev/null || true' EXIT
start=$(date +%s)
while kill -0 "$eval_pid" 2>/dev/null; do
  for p in rumi-front rumi-back rumi-manager colmap; do
    kib=$({ ps -C "$p" -o rss= 2>/dev/null || true; } | awk '{s += $1} END {print s + 0}')
    echo -e "$(( $(date +%s) - start ))\t$p\t$kib" >> "$rss"
  done
  sleep 10
done
trap - EXIT
wait "$eval_pid" || { echo "stress: rumi eval run failed; $out/eval.log" >&2; tail -20 "$out/eval.log" >&2; exit 1; }
python3 - "$run/run_1" "$rss" "$(( $(date +%s) - start ))" <<'EOF'
import json, sys, collections
run, rss_path, wall = sys.argv[1], sys.argv[2], int(sys.argv[3])
back = json.load(open(run + "/back/back_stats.json"))
m = json.load(open(run + "/metrics.json"))
print(f"run {run}: {wall} s wall, sequence {m['duration_s']:.0f} s")
print(f"front rate {100 * m['front_tracking_rate_time']:.1f} %, merged {100 * m['merged_tracking_rate_time']:.1f} %, "
      f"merges {m['merges']}")
print(f"back: received {back['windows_received']}, joined {back['windows_joined']}, dropped {back['windows_dropped']}, "
      f"built {back['windows']} ({back['windows_done']} ok, {back['windows_failed']} failed)")
hist = back.get("queue_history", [])
if hist:
    t0 = hist[0][0]
    per_min = collections.OrderedDict()
    for t, n in hist:
        k = int((t - t0) // 60)
        per_min[k] = max(per_min.get(k, 0), n)
    print("queue, max waiting windows per minute: " + " ".join(f"{k}:{v}" for k, v in per_min.items()))
for w in back["per_window"]:
    print(f"  window {w['window_id']}: {w['frames']} frames, joined {w['joined_windows']}, "
          f"{w['status']}, registered {w['registered']}, build {w['seconds']['total']:.0f} s")
if m.get("losses") is not None:
    print(f"losses {m['losses']}, merged {m['losses_merged']}; loss to merge p50 {m['loss_to_merge_p50_s']} s, "
          f"p95 {m['loss_to_merge_p95_s']} s, max {m['loss_to_merge_max_s']} s")
    print("  per loss (s): " + " ".join("-" if l["seconds"] is None else f"{l['seconds']:.0f}"
                                       for l in m["loss_to_merge"]))
first, last = {}, {}
for line in open(rss_path).read().split("\n")[1:]:
    if not line: continue
    t, p, kib = line.split("\t")
    if int(kib) == 0: continue
    first.setdefault(p, (int(t), int(kib)))
    last[p] = (int(t), int(kib))
peak = collections.defaultdict(int)
for line in open(rss_path).read().split("\n")[1:]:
    if line:
        t, p, kib = line.split("\t")
        peak[p] = max(peak[p], int(kib))
for p in first:
    print(f"RSS {p}: {first[p][1] / 1024:.0f} MiB at {first[p][0]} s, {last[p][1] / 1024:.0f} MiB at {last[p][0]} s, "
          f"peak {peak[p] / 1024:.0f} MiB")
EOF
