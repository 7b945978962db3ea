#!/usr/bin/env bash
# The relay's cost (BENCHMARKS.md, "netkf relay"): a Cyclone DDS talker and listener of
# rt/chatter (tests/interop/netkf_cyclone_chatter.c), once on one domain (a bare hop) and once
# through `netkf relay` with a lossless link (two hops: Cyclone -> relay -> Cyclone), for payloads
# of 100 B, 10 kB and 1 MB written as fast as the writer takes them. Throughput at the listener
# (samples and MB per second between its first and last arrival), the samples it got, and the
# relay's CPU time per relayed sample (/proc/PID/stat). Talker and listener keep all samples (a
# fast talker waits for its readers); the relay keeps the last 10000. Run inside scripts/in-netns.sh.
# Usage: bench/bench_relay.sh BUILD_DIR WORKDIR
set -euo pipefail
bin=$1 dir=$2
chatter=$bin/tests/interop/netkf_cyclone_chatter
netkf=$bin/cli/netkf
export CYCLONEDDS_URI=file://$(cd "$(dirname "$0")/.." && pwd)/deploy/dds/cyclonedds-localhost.xml
mkdir -p "$dir"
# Domains far apart: Fast DDS 2.9 discovers the next domain's first participants (docs/relay.md).
from=153 to=157
hz() { awk '{print $14 + $15}' "/proc/$1/stat"; }   # utime + stime, clock ticks
tick=$(getconf CLK_TCK)

rate_line() {  # label bytes count listener-output relay-cpu-ticks
  read -r _ n _ b _ first _ last <"$4"
  awk -v label="$1" -v bytes="$2" -v sent="$3" -v n="$n" -v b="$b" -v first="$first" -v last="$last" \
      -v ticks="$5" -v tick="$tick" 'BEGIN {
    span = last - first; rate = (n > 1 && span > 0) ? (n - 1) / span : 0
    cpu = (ticks == "" || n == 0) ? "–" : sprintf("%.1f µs", 1e6 * ticks / tick / n)
    printf "| %s | %s | %d of %d | %.0f | %.1f | %s |\n", bytes, label, n, sent, rate, rate * bytes / 1e6, cpu }'
}

echo "| payload (bytes) | path | samples received | samples/s | MB/s | relay CPU per sample |"
echo "|---|---|---|---|---|---|"
for bytes in 100 10000 1000000; do
  count=20000
  [ "$bytes" -ge 10000 ] && count=5000
  [ "$bytes" -ge 1000000 ] && count=200
  # A bare hop: talker and listener on one domain.
  "$chatter" listen --domain $from --duration 120 --count-only --keep-all >"$dir/bare-$bytes.txt" 2>"$dir/bare-$bytes.log" &
  listener=$!
  sleep 0.5
  "$chatter" talk --domain $from --count $count --bytes "$bytes" --rate-hz 100000 --keep-all --settle 1 2>>"$dir/bare-$bytes.log"
  sleep 1
  kill -INT $listener && wait $listener
  rate_line "bare hop (Cyclone → Cyclone)" "$bytes" $count "$dir/bare-$bytes.txt" ""
  # Through the relay.
  "$chatter" listen --domain $to --duration 120 --count-only --keep-all >"$dir/relay-$bytes.txt" 2>"$dir/relay-$bytes.log" &
  listener=$!
  "$netkf" relay --from-domain $from --to-domain $to --topic rt/chatter --bernoulli 0 --depth 10000 \
    >"$dir/relay-$bytes.out" 2>&1 &
  relay=$!
  sleep 1
  before=$(hz $relay)
  "$chatter" talk --domain $from --count $count --bytes "$bytes" --rate-hz 100000 --keep-all --settle 2 2>>"$dir/relay-$bytes.log"
  sleep 1
  after=$(hz $relay)
  kill -INT $relay && wait $relay
  kill -INT $listener && wait $listener
  rate_line "through netkf relay (lossless)" "$bytes" $count "$dir/relay-$bytes.txt" $((after - before))
done
