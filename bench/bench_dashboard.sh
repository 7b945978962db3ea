#!/usr/bin/env bash
# What the dashboard costs the live network (BENCHMARKS.md; a benchmark, not a test):
#  1. pipeline latency by bench_latency's protocol (3 sensors at 100 Hz), alternating runs
#     without a client, with one headless Chromium on the page, and with a Foxglove
#     protocol client (Node, subscribed to netkf/estimate: the server's cost without the
#     browser's rendering);
#  2. the CPU of the `netkf launch` process itself (default scenario: 3 sensors at 100 Hz),
#     without and with a browser connected, from /proc/PID/stat over the same window.
# Runs inside scripts/in-netns.sh (its own network namespace, port 8470 there only).
# Usage: bench/bench_dashboard.sh [RUNS] [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
seconds=${2:-20}
exec scripts/in-netns.sh bash -s "$runs" "$seconds" <<'INNER'
set -euo pipefail
runs=$1 seconds=$2
netkf=build/default/cli/netkf
browser() {  # one browser on the page for $1 seconds, no link change
  node tests/e2e/dashboard_browser.mjs --url http://127.0.0.1:8470/ --screenshot /tmp/bench-dashboard.png --no-set \
    --seconds "$1" --timeout $(( $1 + 60 )) > /dev/null
}
echo "== pipeline latency (bench_latency --sensors 3), $runs x $seconds s each"
for i in $(seq 1 "$runs"); do
  for mode in without browser client; do
    if [ "$mode" = browser ]; then
      build/default/bench/bench_latency --sensors 3 --seconds "$seconds" --warmup 3 --domain 150 > /tmp/bench-dash.txt &
      sleep 4; browser "$seconds" || echo "  (browser ended with an error)"; wait
    elif [ "$mode" = client ]; then
      build/default/bench/bench_latency --sensors 3 --seconds "$seconds" --warmup 3 --domain 150 > /tmp/bench-dash.txt &
      sleep 4
      node tests/e2e/foxglove_client.mjs --url ws://127.0.0.1:8470/ --seconds "$seconds" --topic netkf/estimate > /dev/null \
        || echo "  (client ended with an error)"
      wait
    else
      build/default/bench/bench_latency --sensors 3 --seconds "$seconds" --warmup 3 --domain 150 > /tmp/bench-dash.txt
    fi
    printf 'run %d %-8s %s\n' "$i" "$mode" "$(grep -m1 'sample publish -> estimate publish' /tmp/bench-dash.txt)"
  done
done
echo "== CPU of the launch process (default scenario, 3 sensors at 100 Hz), $seconds s window"
ticks=$(getconf CLK_TCK)
for i in $(seq 1 "$runs"); do
  for mode in without with; do
    $netkf launch --duration $(( seconds + 12 )) --domain 151 --status-interval 1 2> /dev/null &
    launch=$!
    sleep 5
    if [ "$mode" = with ]; then browser $(( seconds + 4 )) & fi
    sleep 3
    read -r -a a < /proc/$launch/stat
    sleep "$seconds"
    read -r -a b < /proc/$launch/stat
    cpu=$(( (b[13] + b[14]) - (a[13] + a[14]) ))
    awk -v c="$cpu" -v t="$ticks" -v s="$seconds" -v i="$i" -v m="$mode" \
      'BEGIN { printf "run %d %-8s launch CPU %.2f %% of one core\n", i, m, 100 * c / t / s }'
    wait
  done
done
INNER
