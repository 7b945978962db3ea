#!/usr/bin/env bash
# Set-up and CI time (BENCHMARKS.md, "Set-up and CI time"): the README's two commands on a fresh
# clone of one commit, as a new user runs them, cold (an empty compiler cache and an empty npm
# cache of their own, never the shared ones) and then warm (the same commands again, nothing
# changed), then the build of a second clone at another path on the now-warm cache (ccache across
# clones). The demo's live run happens inside scripts/in-netns.sh; apt is not measured (every
# package is installed here). Everything is written under WORKDIR, which this script creates.
# Usage: bench/bench_setup.sh REV WORKDIR [DURATION]
#   REV: the commit to measure (e.g. HEAD); DURATION: the demo's --duration (10 s).
set -euo pipefail
src=$(cd "$(dirname "$0")/.." && pwd)
rev=$(git -C "$src" rev-parse "$1")
work=$2
duration=${3:-10}
mkdir "$work"  # fails if it exists: nothing here is overwritten
work=$(cd "$work" && pwd)
here=$(cd "$(dirname "$0")" && pwd)

export CCACHE_DIR=$work/ccache npm_config_cache=$work/npm-cache
mkdir -p "$CCACHE_DIR" "$npm_config_cache"
unset CCACHE_BASEDIR CCACHE_NOHASHDIR

# Machine load through the whole run: the 1-minute load average and the share of both cores
# that was idle, every 2 s (the other users of the machine are in these numbers too).
sample() {
  local prev now
  prev=$(awk '/^cpu / {print $2+$3+$4+$5+$6+$7+$8, $5+$6}' /proc/stat)
  while sleep 2; do
    now=$(awk '/^cpu / {print $2+$3+$4+$5+$6+$7+$8, $5+$6}' /proc/stat)
    read -r t0 i0 <<<"$prev"
    read -r t1 i1 <<<"$now"
    printf '%s %s %s\n' "$EPOCHREALTIME" "$(cut -d' ' -f1 /proc/loadavg)" \
      "$(awk -v dt=$((t1 - t0)) -v di=$((i1 - i0)) 'BEGIN {printf "%.3f", (dt > 0 ? di / dt : 0)}')"
    prev=$now
  done >>"$work/load.txt"
}
sample &
sampler=$!
trap 'kill $sampler 2>/dev/null || true' EXIT

# (BENCH_TRACE, not NETKF_*: scripts/test.sh keys its "nothing changed" check on NETKF_* variables.)
# traced NAME SCRIPT ARGS...: run SCRIPT (prefixed by the array `wrap`) with its top-level
# commands traced to NAME.trace (wall clock, and the user+sys ticks of the shell's finished
# children), its output to NAME.log and /usr/bin/time -v's summary to NAME.time.
wrap=()
traced() {
  local name=$1 rc=0
  shift
  echo "--- $name: $* (load $(cut -d' ' -f1-3 /proc/loadavg))" >&2
  echo "$EPOCHREALTIME start" >"$work/$name.trace"
  # shellcheck disable=SC2016  # expanded by the traced shell
  BENCH_TRACE=$work/$name.trace /usr/bin/time -v -o "$work/$name.time" "${wrap[@]}" bash -c \
    'exec 9>>"$BENCH_TRACE"; BASH_XTRACEFD=9; PS4='"'"'+ ${EPOCHREALTIME} $(cut -d" " -f16,17 /proc/$$/stat) '"'"'; set -x; . "$0"' \
    "$@" >"$work/$name.log" 2>&1 || rc=$?
  echo "$EPOCHREALTIME end $rc" >>"$work/$name.trace"
  echo "--- $name: exit $rc" >&2
  return 0
}

# One user's session: clone, the demo, the tests; then both again (warm).
clone=$work/netkf
git clone -q --no-hardlinks "$src" "$clone"
git -C "$clone" checkout -q "$rev"
cd "$clone"
export CI=true  # as .ci/run: the Cyclone DDS interop test runs, never skips
traced cold-deps scripts/deps.sh
wrap=(scripts/in-netns.sh)
traced cold-demo scripts/demo.sh --duration "$duration"
wrap=(nice -n 5)
traced cold-test scripts/test.sh
ccache -s >"$work/ccache-after-cold.txt" 2>&1 || true
for tree in build/*/; do
  tree=$(basename "$tree")
  cp "build/$tree/.ninja_log" "$work/ninja-$tree-cold.log" 2>/dev/null || true
  cp "build/$tree/Testing/Temporary/CTestCostData.txt" "$work/ctest-cost-$tree-cold.txt" 2>/dev/null || true
  cp "build/$tree/Testing/Temporary/LastTest.log" "$work/ctest-$tree-cold.log" 2>/dev/null || true
done
wrap=(scripts/in-netns.sh)
traced warm-demo scripts/demo.sh --duration "$duration"
wrap=(nice -n 5)
traced warm-test scripts/test.sh
for tree in build/*/; do
  tree=$(basename "$tree")
  cp "build/$tree/Testing/Temporary/CTestCostData.txt" "$work/ctest-cost-$tree-warm.txt" 2>/dev/null || true
done

# A second clone at another path on the same (now warm) cache: what a CI checkout with a kept
# cache pays for the builds.
ccache -z >/dev/null
clone2=$work/second-clone
git clone -q --no-hardlinks "$src" "$clone2"
git -C "$clone2" checkout -q "$rev"
cp -a "$clone/node_modules" "$clone2/node_modules"
cd "$clone2"
wrap=(nice -n 5)
traced clone2-build-default scripts/build.sh default
ccache -s >"$work/ccache-clone2.txt" 2>&1 || true

kill $sampler 2>/dev/null || true
python3 "$here/bench_setup_report.py" "$work"
