#!/usr/bin/env bash
# Many sensors at a high rate (BENCHMARKS.md, "256 sensors at 100 Hz"): one `netkf launch` of N
# scalar sensors (a 2-state plant, Bernoulli loss 0.1 per link, the launch's automatic grouping)
# for S seconds inside scripts/in-netns.sh, while the RSS and open file descriptors of every
# process of the run are sampled every 10 s. Prints one markdown row: periods, fused per period
# against the links' 0.9 N, late share, pipeline latency p50/p99, RSS and fds at 30 s and at the
# end (summed over the processes), the launch's exit status.
# Usage: bench/bench_sensor_rate.sh N PERIOD_MS SECONDS [DOMAIN] [path/to/netkf]
set -euo pipefail
cd "$(dirname "$0")/.."
n=$1 period=$2 seconds=$3 domain=${4:-60} netkf=${5:-build/default/cli/netkf}
dir=$(mktemp -d)
[ -n "${KEEP:-}" ] || trap 'rm -rf "$dir"' EXIT

bench/rate_scenario.sh "rate-$n-${period}ms" "$n" "$period" >"$dir/s.yaml"

NETKF_DOMAIN=$domain scripts/in-netns.sh "$netkf" launch "$dir/s.yaml" --duration "$seconds" --dashboard off \
  --record "$dir/p.csv" --summary "$dir/summary.json" --pid-file "$dir/pids.txt" >"$dir/launch.log" 2>&1 &
launch=$!

# RSS (kB) and fds summed over the run's processes (the launch and its children).
usage() {
  local rss=0 fds=0 pid r
  for pid in $(awk '{print $NF}' "$dir/pids.txt" 2>/dev/null) $launch; do
    [ -d "/proc/$pid" ] || continue
    r=$(awk '/^VmRSS/ {print $2}' "/proc/$pid/status" 2>/dev/null || echo 0)
    rss=$((rss + ${r:-0}))
    fds=$((fds + $(find "/proc/$pid/fd" -mindepth 1 -maxdepth 1 2>/dev/null | wc -l)))
  done
  echo "$rss $fds"
}
elapsed=0 first="" last="" peak_rss=0
while kill -0 "$launch" 2>/dev/null; do
  sleep 10
  elapsed=$((elapsed + 10))
  [ "$elapsed" -lt "$seconds" ] || break
  now=$(usage)
  kill -0 "$launch" 2>/dev/null || break  # ended while sampling: not a sample of the run
  [ "$elapsed" -eq 30 ] && first=$now
  [ "$elapsed" -ge 30 ] && last=$now
  peak_rss=$(( ${now%% *} > peak_rss ? ${now%% *} : peak_rss ))
  echo "$elapsed s: RSS ${now%% *} kB, fds ${now##* }" >&2
done
rc=0
wait "$launch" || rc=$?

python3 - "$dir" "$n" "$period" "$seconds" "$rc" "$first" "$last" "$peak_rss" <<'PY'
import csv, json, sys
d, n, period, seconds, rc, first, last, peak = sys.argv[1:9]
n = int(n)
s = json.load(open(d + "/summary.json"))
fused = []
with open(d + "/p.csv") as f:
    for row in csv.DictReader(f):
        fused.append(len([x for x in row["fused"].split(";") if x]))
mean = sum(fused) / max(1, len(fused))
thin = [k for k, f in enumerate(fused) if f < 0.45 * n]
print("periods with fewer than half the expected fused: %d%s" % (len(thin), (" (k = %s)" % thin[:20]) if thin else ""),
      file=sys.stderr)
def mb(v): return "%.0f" % (int(v.split()[0]) / 1024) if v else "?"
def fd(v): return v.split()[1] if v else "?"
late = s.get("late_fraction")
print("| %d at %g Hz, %d s | %d | %.1f; %d–%d | %.1f | %s | %.3f / %.3f ms | %s → %s (peak %.0f) | %s → %s | %s |" % (
    n, 1000.0 / int(period), int(seconds), s["periods"], mean, min(fused or [0]), max(fused or [0]), 0.9 * n,
    "%.4f %%" % (100 * late) if late is not None else "n/a",
    s.get("pipeline_latency_p50_ms") or 0, s.get("pipeline_latency_p99_ms") or 0,
    mb(first), mb(last), int(peak) / 1024, fd(first), fd(last), rc))
PY
