#!/usr/bin/env bash
# Wall time of `netkf analyze FILE --json` (including the critical rates, lambda_upper by the
# CSDP LMI where its size allows) for every shipped scenario and the theory test scenarios.
# Usage: bench/bench_analyze.sh [path/to/netkf]   (default: build/default/cli/netkf)
set -euo pipefail
cd "$(dirname "$0")/.."
netkf=${1:-build/default/cli/netkf}
printf '| scenario | wall time (s), best of 3 |\n|---|---|\n'
for f in deploy/scenarios/*.yaml tests/data/theory/*.yaml; do
  best=""
  for _ in 1 2 3; do
    t=$( { /usr/bin/time -f '%e' "$netkf" analyze "$f" --json >/dev/null; } 2>&1 )
    if [ -z "$best" ] || awk "BEGIN{exit !($t < $best)}"; then best=$t; fi
  done
  printf '| %s | %s |\n' "$f" "$best"
done
