#!/usr/bin/env bash
# Theory beyond 16 sensors: wall and CPU time of `netkf analyze FILE --json` for 512-sensor
# scenarios (the criterion by observation classes, V-bar grouped or sampled;
# docs/validation.md "Beyond 16 sensors"). Prints a markdown table for BENCHMARKS.md.
# Usage: bench/bench_many_sensors.sh [path/to/netkf]   (default: build/default/cli/netkf)
set -euo pipefail
cd "$(dirname "$0")/.."
netkf=${1:-build/default/cli/netkf}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT

# name, A, C of sensor i (printf pattern over i), link
write() {
  local file=$1 A=$2 cfmt=$3 link=$4 i
  {
    printf 'name: %s\nperiod_ms: 100\nseed: 5\nplant:\n  A: %s\n' "$(basename "$file" .yaml)" "$A"
    printf '  Q: [[1.0, 0.0], [0.0, 1.0]]\n  x0: [0.0, 0.0]\nsensors:\n'
    for i in $(seq 1 512); do
      # shellcheck disable=SC2059  # the C pattern is the argument
      printf "  - { id: %d, C: [[$cfmt]], R: [[1.0]], link: { %s } }\n" "$i" "$i" "$link"
    done
    printf 'estimator:\n  deadline_ms: 80\n'
  } >"$file"
}
write "$dir/identical-bernoulli.yaml" '[[1.2, 0.1], [0.0, 0.9]]' '1.0, 0.0%.0s' 'model: bernoulli, loss: 0.99'
write "$dir/distinct-bernoulli.yaml" '[[1.2, 0.1], [0.0, 0.9]]' '1.0, %d.0e-3' 'model: bernoulli, loss: 0.99'
write "$dir/distinct-gilbert.yaml" '[[1.2, 0.1], [0.0, 0.9]]' '1.0, %d.0e-3' 'model: gilbert_elliott, p: 0.1, r: 0.02, loss_good: 0.0, loss_bad: 1.0'
write "$dir/rotation-distinct.yaml" '[[0.0, -1.05], [1.05, 0.0]]' '1.0, %d.0e-3' 'model: bernoulli, loss: 0.5'

printf '| scenario (512 sensors) | stable | upper_method | wall (s), best of 3 | CPU user+sys (s) |\n|---|---|---|---|---|\n'
for f in "$dir"/*.yaml; do
  best="" cpu=""
  for _ in 1 2 3; do
    out=$( { /usr/bin/time -f '%e %U %S' "$netkf" analyze "$f" --json >"$dir/out.json"; } 2>&1 )
    read -r wall user sys <<<"$out"
    if [ -z "$best" ] || awk "BEGIN{exit !($wall < $best)}"; then best=$wall; cpu=$(awk "BEGIN{print $user + $sys}"); fi
  done
  verdict=$(python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(r['stable'], r['expected_covariance'].get('upper_method'))" "$dir/out.json")
  printf '| %s | %s | %s | %s | %s |\n' "$(basename "$f" .yaml)" "${verdict% *}" "${verdict#* }" "$best" "$cpu"
done
