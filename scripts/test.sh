#!/usr/bin/env bash
# Quick start 2: install what is missing, build, and run every test: the full suite (unit,
# validation, integration, e2e, python, deploy) on the normal build, then unit, validation and
# integration again under ASan+UBSan (one tree, preset asan, that builds only their test
# programs), then a short run of each libFuzzer target on its seed corpus (clang-14,
# tests/fuzz). Ends with the tests run and passed per suite and the time of each step.
# A second run on a checkout where nothing changed since a run that passed (sources, installed
# packages, build trees) says so and stops; --again runs everything anyway.
# Usage: scripts/test.sh [--again]
set -euo pipefail
cd "$(dirname "$0")/.."
again=false
case ${1:-} in
  --again) again=true ;;
  "") ;;
  *) echo "usage: scripts/test.sh [--again]" >&2; exit 2 ;;
esac

steps=()
step_start=$EPOCHREALTIME
# done_step NAME: the wall time since the previous step ended, for the summary at the end.
done_step() {
  steps+=("$(awk -v a="$step_start" -v b="$EPOCHREALTIME" -v n="$1" 'BEGIN {printf "%-34s %6.0f s", n, b - a}')")
  step_start=$EPOCHREALTIME
}

scripts/deps.sh
done_step "deps"

# What the tests ran on: the commit, every change to it (untracked files too), the installed
# packages, the page's npm lock and the environment the suites read, and whether every build tree
# is up to date. Empty outside a git checkout (then everything always runs).
stamp=build/tests-passed.txt
tree_key() {
  git rev-parse --is-inside-work-tree >/dev/null 2>&1 || return 0
  {
    git rev-parse HEAD
    git diff HEAD --binary
    git ls-files -z --others --exclude-standard | xargs -0 -r sha256sum
    dpkg-query -W -f='${Package} ${Version}\n'
    cat node_modules/.netkf-lock-hash 2>/dev/null || true
    env | grep -E '^(CI|NETKF_[A-Z_]*)=' | sort || true
    for tree in default asan fuzz; do
      echo "$tree: $(ninja -C "build/$tree" -n 2>&1 | tail -1)"
    done
  } | sha256sum | cut -d' ' -f1
}
key=$(tree_key)
if ! $again && [ -n "$key" ] && [ -f "$stamp" ] && [ "$(head -1 "$stamp")" = "$key" ]; then
  echo "=== nothing changed since every test passed ($(sed -n 2p "$stamp")); not run again"
  echo "    (scripts/test.sh --again runs them anyway). That run's totals:"
  tail -n +3 "$stamp"
  exit 0
fi
rm -f "$stamp"

slots=$((2 * $(nproc)))  # the cpu slots of ctest-resources.json (tests/CMakeLists.txt)
scripts/build.sh default
done_step "build default"
# An end-to-end test runs real processes on this 2-core machine; one that fails is run once
# more, alone, and passes CI only if it then passes (so does python_reader, which launches
# the network too). Every first failure is listed at the
# end with its failed expectations, so a flaky test stays visible. Any other test that
# fails, or an e2e test that fails twice, fails CI.
second_tries=build/default/e2e-second-tries.txt
rm -f "$second_tries" build/default/ctest-second.log
if ! ctest --preset default --parallel "$slots" --timeout 600 2>&1 | tee build/default/ctest-first.log; then
  failed=$(cut -d: -f2 build/default/Testing/Temporary/LastTestsFailed.log)
  if grep -qvE '^(e2e_|python_reader$)' <<<"$failed"; then
    echo "failed (not only e2e tests):" $failed
    exit 1
  fi
  echo "e2e tests failed on the first run, running them once more: " $failed
  ctest --preset default --timeout 600 --rerun-failed 2>&1 | tee build/default/ctest-second.log
  for t in $failed; do
    echo "$t failed on the first run and passed on the second; its failed expectations then:"
    sed -n "/Test *#[0-9]*: $t /,/Test *#[0-9]*: /p" build/default/ctest-first.log | grep -E 'FAILED:|^FAILED ' || true
  done >"$second_tries"
fi
done_step "tests default"

# Unit, validation and integration (in-process Fast DDS, every node's app class, the dashboard
# server, DDS Security) under ASan+UBSan: only their test programs are built.
scripts/build.sh asan unit_tests validation_tests integration_tests
done_step "build asan (test programs)"
ctest --preset asan --parallel "$slots" --timeout 900 -L 'unit|validation|integration' 2>&1 | tee build/asan/ctest.log
done_step "tests asan"
scripts/build.sh fuzz
done_step "build fuzz"
ctest --preset fuzz --parallel "$(nproc)" -L fuzz 2>&1 | tee build/fuzz/ctest.log
done_step "tests fuzz"

if [ -s "$second_tries" ]; then
  echo "=== passed, but these e2e tests needed a second run:"
  cat "$second_tries"
fi
totals=$(python3 scripts/ctest_totals.py \
  "default:build/default/ctest-first.log:build/default/ctest-second.log" \
  "asan:build/asan/ctest.log" "fuzz:build/fuzz/ctest.log")
echo "=== tests run and passed, per suite"
echo "$totals"
echo "=== time per step"
printf '%s\n' "${steps[@]}"
key=$(tree_key)  # now that every tree is built
if [ -n "$key" ]; then
  printf '%s\n%s\n%s\n' "$key" "$(date -u '+%Y-%m-%d %H:%M UTC')" "$totals" >"$stamp"
fi
