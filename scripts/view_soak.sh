#!/usr/bin/env bash
# The web view over a long session (benchmark, not a test): scripts/soak.sh
# runs rumid for MINUTES on its looped sequence while one page follows the
# live stream (`curl -N /api/events`, what a browser costs the server);
# every minute it prints the stream's bytes per second and the whole map's
# size (`/api/map`), and at a few points the time headless Chromium takes to
# load the page (`?live=0`, against `about:blank` the same way); at the
# end, what the stream carried by event (count, bytes, bytes/s, share).
#   scripts/view_soak.sh [MINUTES] [OUT] [SEQUENCE]   (defaults 20, /tmp/rumi-view-soak, dark)
set -euo pipefail
cd "$(dirname "$0")/.."
minutes=${1:-20}
out=${2:-/tmp/rumi-view-soak}
sequence=${3:-dark}
port=${VIEW_PORT:-8766}
url="http://127.0.0.1:$port"
command -v curl > /dev/null || { echo "view_soak: curl missing" >&2; exit 1; }
command -v chromium > /dev/null || { echo "view_soak: chromium missing (apt install chromium)" >&2; exit 1; }
mkdir -p "$out"
SOAK_YAML="view: {port: $port}${SOAK_YAML:+
$SOAK_YAML}" scripts/soak.sh "$minutes" "$out" "$sequence" > "$out/soak.log" 2>&1 &
soak=$!
trap 'kill $soak 2>/dev/null || true; kill $follow 2>/dev/null || true' EXIT
follow=
for _ in $(seq 1 120); do curl -sf "$url/api/state" > /dev/null && break; sleep 1; done
curl -sN "$url/api/events" -o "$out/events.sse" &
follow=$!
follow_t0=$(date +%s)
load_ms() {  # the page (or about:blank) loaded and its script run, in ms
  local t0 t1
  t0=$(date +%s%N)
  chromium --headless --no-sandbox --disable-gpu --no-first-run --mute-audio --virtual-time-budget=2000 \
    --dump-dom "$1" > "$out/dom.html" 2> /dev/null || true
  t1=$(date +%s%N)
  echo $(( (t1 - t0) / 1000000 ))
}
printf '%6s %12s %10s %10s %12s %12s\n' minute stream_bytes bytes_s map_bytes page_ms blank_ms
prev=0
for m in $(seq 1 "$minutes"); do
  sleep 60
  kill -0 "$soak" 2>/dev/null || break
  [ "$m" -lt "$minutes" ] || break  # the soak stops rumid now
  now=$(stat -c %s "$out/events.sse" 2>/dev/null || echo 0)
  map=$( (curl -s "$url/api/map" || true) | wc -c)
  page=- blank=-
  if [ "$m" -eq 1 ] || [ $(( m % 5 )) -eq 0 ] || [ "$m" -eq "$((minutes - 1))" ]; then
    page=$(load_ms "$url/?live=0")
    blank=$(load_ms "about:blank")
  fi
  printf '%6d %12d %10d %10d %12s %12s\n' "$m" "$now" $(( (now - prev) / 60 )) "$map" "$page" "$blank"
  prev=$now
done
wait "$soak" || true
kill "$follow" 2>/dev/null || true
follow_s=$(( $(date +%s) - follow_t0 ))
trap - EXIT
grep -E '^soak:|^per hour|^from ' "$out/soak.log" || true
# What the stream carried, by event (": idle" keep-alives apart), over the $follow_s s it was followed.
echo "the stream by event, $follow_s s followed:"
LC_ALL=C awk -v s="$follow_s" '
  /^event: / { k = $2; n[k]++ }
  /^:/ { k = "(idle)"; n[k]++ }
  { b[k] += length($0) + 1; all += length($0) + 1 }
  END {
    printf "%-14s %8s %12s %10s %8s %6s\n", "event", "count", "bytes", "each", "bytes/s", "share"
    by_size = "sort -k3 -n -r"
    for (k in b) printf "%-14s %8d %12d %10d %8d %5.1f%%\n", k, n[k], b[k], b[k] / n[k], b[k] / s, 100 * b[k] / all | by_size
    close(by_size)
    printf "%-14s %8s %12d %10s %8d\n", "all", "", all, "", all / s
  }' "$out/events.sse"
