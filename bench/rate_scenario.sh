#!/usr/bin/env bash
# Prints the scenario of the many-sensor benchmarks (bench_sensor_rate.sh, bench_dashboard_many.sh):
# N scalar sensors of a 2-state plant, Bernoulli loss 0.1 per link (link WORST, if given, 0.9),
# period PERIOD_MS, deadline 80 % of it.
# Usage: bench/rate_scenario.sh NAME N PERIOD_MS [WORST]
set -euo pipefail
name=$1 n=$2 period=$3 worst=${4:-0}
printf 'name: %s\nperiod_ms: %d\nseed: 5\nplant:\n  A: [[0.95, 0.1], [0.0, 0.9]]\n' "$name" "$period"
printf '  Q: [[0.1, 0.0], [0.0, 0.1]]\n  x0: [0.0, 0.0]\nsensors:\n'
for i in $(seq 1 "$n"); do
  loss=0.1; [ "$i" -eq "$worst" ] && loss=0.9
  printf '  - { id: %d, C: [[1.0, 0.0]], R: [[1.0]], link: { model: bernoulli, loss: %s } }\n' "$i" "$loss"
done
printf 'estimator:\n  deadline_ms: %d\n' $((period * 8 / 10))
