#!/usr/bin/env bash
# The README's main job: set up and build, generate a challenge sequence with
# exact ground truth, run the three-process pipeline (front, back, manager) on
# it with `rumi eval run`, and print the paper-style table.
#   RUMI_DEMO_DIR  where to write (default /tmp/rumi-demo)
#   RUMI_DEMO_SCENARIO  smooth|blur|dark|drop|weak|kidnap|corridor (default dark)
#   RUMI_DEMO_SYNTH_ARGS  extra `rumi synth` flags (default for dark: a near-black
#                         stretch that makes the front lose track)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh

out=${RUMI_DEMO_DIR:-/tmp/rumi-demo}
scenario=${RUMI_DEMO_SCENARIO:-dark}
seq="$out/$scenario"
mkdir -p "$out"
if [ ! -f "$seq/scenario.json" ]; then
  echo "demo: generating the '$scenario' sequence into $seq (takes a minute or two)"
  default_args=""
  [ "$scenario" = dark ] && default_args="--dark-gain 0.02"
  # shellcheck disable=SC2086
  build/bin/rumi synth "$seq" --scenario "$scenario" --seed 2 --frames 300 ${RUMI_DEMO_SYNTH_ARGS:-$default_args}
fi
rm -rf "$out/eval_$scenario"
build/bin/rumi eval run "$seq" --dataset tum --config "$seq/camera.yaml" \
  --out "$out/eval_$scenario" --sequence "$scenario"
echo "demo: trajectories, metrics.json and plots are in $out/eval_$scenario/run_1"
