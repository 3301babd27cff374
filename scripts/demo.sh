#!/usr/bin/env bash
# The README's main job: the product. Sets up and builds what it runs (not
# the tests), generates a challenge sequence with exact ground truth, starts
# rumid on it as a live source (the sequence replayed at its recorded rate,
# as a camera would deliver it), shows `rumi status` while the daemon runs,
# and prints the evaluation table of the session at the end.
#   RUMI_DEMO_DIR       where to write (default /tmp/rumi-demo)
#   RUMI_DEMO_SCENARIO  smooth|blur|dark|drop|weak|kidnap|corridor (default dark)
#   RUMI_DEMO_SYNTH_ARGS  extra `rumi synth` flags (default for dark: a near-black
#                         stretch that makes the front lose track)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh rumid rumi rumi-front rumi-back rumi-manager rumi-ipc-status

out=${RUMI_DEMO_DIR:-/tmp/rumi-demo}
scenario=${RUMI_DEMO_SCENARIO:-dark}
seq="$out/$scenario"
state="$out/state_$scenario"
mkdir -p "$out"
if [ ! -f "$seq/scenario.json" ]; then
  echo "demo: generating the '$scenario' sequence into $seq (takes a minute or two)"
  default_args=""
  [ "$scenario" = dark ] && default_args="--dark-gain 0.02"
  # shellcheck disable=SC2086
  build/bin/rumi synth "$seq" --scenario "$scenario" --seed 2 --frames 300 ${RUMI_DEMO_SYNTH_ARGS:-$default_args}
fi
rm -rf "$state"
echo "demo: rumid --config configs/daemon.yaml --dataset tum $seq --state-dir $state --instance demo"
echo "demo: (the sequence plays live for 10 s; then the back rebuilds what the front lost, which takes minutes)"
build/bin/rumid --config configs/daemon.yaml --dataset tum "$seq" --state-dir "$state" --instance demo \
  > "$out/rumid_$scenario.log" 2>&1 &
rumid=$!
trap 'kill -TERM $rumid 2>/dev/null || true' EXIT INT TERM
shown=0
while kill -0 "$rumid" 2>/dev/null; do
  sleep 5
  [ -f "$state/status.json" ] || continue
  if [ "$shown" -eq 0 ] && grep -q '"state": "running"' "$state/status.json"; then
    sleep 3
    echo
    echo "demo: rumi status --state-dir $state"
    build/bin/rumi status --state-dir "$state" || true
    echo
    view=$(grep -o '"view": "[^"]*"' "$state/status.json" | cut -d'"' -f4 || true)
    [ -n "$view" ] && echo "demo: watch the map live in a browser: $view (docs/view.md)" && echo
    shown=1
  else
    echo "demo: $(build/bin/rumi status --brief --state-dir "$state" 2>/dev/null || true)"
  fi
done
trap - EXIT INT TERM
if ! wait "$rumid"; then
  echo "demo: rumid failed; its log: $out/rumid_$scenario.log" >&2
  tail -n 30 "$out/rumid_$scenario.log" >&2
  exit 1
fi
echo
build/bin/rumi eval session "$state" "$seq" --dataset tum --config "$seq/camera.yaml" --sequence "$scenario"
echo "demo: the map, trajectories, status.json, metrics.json and plots are in $state"
echo "demo: to see the finished session in a browser: build/bin/rumi view $state"
