#!/usr/bin/env bash
# The dashboard and `netkf ctl status` at the size of the largest live network (BENCHMARKS.md,
# "The dashboard at 4096 links"; a benchmark, not a test): one `netkf launch` of N scalar
# sensors (Bernoulli loss 0.1, link N/2 at 0.9 so the table has a known worst link) with the
# dashboard, inside scripts/in-netns.sh. Once the run is up, headless Chromium opens the page
# (tests/e2e/dashboard_browser.mjs --select), searches the worst link and opens its card, stays
# SECONDS on the page, then a late `netkf ctl status --json` is timed. Prints what the page
# measured (messages, redraw and table costs, heap, time to the selected card), the launch's CPU
# over the browser's stay, ctl's wall time and links listed.
# Usage: bench/bench_dashboard_many.sh [N] [PERIOD_MS] [SECONDS] [DOMAIN]
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-4096} period=${2:-100} seconds=${3:-60} domain=${4:-152}
dir=$(mktemp -d)
[ -n "${KEEP:-}" ] || trap 'rm -rf "$dir"' EXIT
worst=$((n / 2))
bench/rate_scenario.sh "dashboard-$n" "$n" "$period" "$worst" >"$dir/s.yaml"

NETKF_DOMAIN=$domain exec scripts/in-netns.sh bash -s "$dir" "$n" "$seconds" "$worst" <<'INNER'
set -euo pipefail
dir=$1 n=$2 seconds=$3 worst=$4
netkf=build/default/cli/netkf
$netkf launch "$dir/s.yaml" --duration $((seconds + 240)) --status-interval 5 --record "$dir/p.csv" \
  --domain "$NETKF_DOMAIN" >"$dir/launch.log" 2>&1 &
launch=$!
# Up: periods recorded, and every link has reported (once a second) for a few seconds.
for _ in $(seq 1 240); do
  [ "$(wc -l 2>/dev/null <"$dir/p.csv" || echo 0)" -gt 100 ] && break
  sleep 1
done
sleep 10
ticks=$(getconf CLK_TCK)
read -r -a a </proc/$launch/stat
start=$(date +%s.%N)
node tests/e2e/dashboard_browser.mjs --url http://127.0.0.1:8470/ --screenshot "$dir/page.png" --no-set \
  --select "$worst" --seconds "$seconds" --timeout $((seconds + 120)) >"$dir/page.json" || true
end=$(date +%s.%N)
read -r -a b </proc/$launch/stat
t0=$(date +%s.%N)
$netkf ctl status --json --domain "$NETKF_DOMAIN" --timeout 30 >"$dir/ctl.json" || true
t1=$(date +%s.%N)
kill -INT $launch; wait $launch || true
python3 - "$dir" "$n" "$worst" "$(( (b[13] + b[14]) - (a[13] + a[14]) ))" "$ticks" "$start" "$end" "$t0" "$t1" <<'PY'
import json, sys
d, n, worst, cpu, ticks, start, end, t0, t1 = sys.argv[1:]
page = json.load(open(d + "/page.json"))
final = page.get("final") or {}
table = page.get("table_before") or {}
sel = page.get("selected") or {}
stay = float(end) - float(start)
try:
    links = len(json.load(open(d + "/ctl.json"))["links"])
except Exception:
    links = "error"
print("page: error %s; %s messages in %.0f s, decode errors %s; first row %s (worst link %s); table redraw (all"
      " links) %s ms; charts redraw %s ms (moving average); card of the searched link shown %s ms after typing;"
      " JS heap %.0f MB; connected at the end: %s; console errors %d"
      % (page.get("error"), final.get("messagesReceived"), stay, final.get("decodeErrors"),
         (table.get("rows") or [{}])[0].get("link"), worst, table.get("redraw_ms"), final.get("redrawMs"), sel.get("ms"),
         page.get("js_heap_mb") or 0, final.get("conn_state"), len(page.get("console_errors") or [])))
print("launch CPU while the page was open: %.1f %% of one core" % (100 * int(cpu) / int(ticks) / stay))
print("late ctl status --json: %.2f s, %s links of %s" % (float(t1) - float(t0), links, n))
PY
INNER
