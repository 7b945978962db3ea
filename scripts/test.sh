#!/usr/bin/env bash
# Quick start 2: install what is missing, build, and run every test: the full suite
# (unit, validation, integration, e2e) on the normal build, then unit, validation and
# integration again under ASan+UBSan, then a short
# run of each libFuzzer target on its seed corpus (clang-14, tests/fuzz).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
jobs=$(nproc)
scripts/build.sh default
# An end-to-end test runs real processes on this 2-core machine; one that fails is run once
# more, alone, and passes CI only if it then passes (so does python_reader, which launches
# the network too). Every first failure is listed at the
# end with its failed expectations, so a flaky test stays visible. Any other test that
# fails, or an e2e test that fails twice, fails CI.
second_tries=build/default/e2e-second-tries.txt
rm -f "$second_tries"
if ! ctest --preset default -j "$jobs" --timeout 600 2>&1 | tee build/default/ctest-first.log; then
  failed=$(cut -d: -f2 build/default/Testing/Temporary/LastTestsFailed.log)
  if grep -qvE '^(e2e_|python_reader$)' <<<"$failed"; then
    echo "failed (not only e2e tests):" $failed
    exit 1
  fi
  echo "e2e tests failed on the first run, running them once more: " $failed
  ctest --preset default --timeout 600 --rerun-failed
  for t in $failed; do
    echo "$t failed on the first run and passed on the second; its failed expectations then:"
    sed -n "/Test *#[0-9]*: $t /,/Test *#[0-9]*: /p" build/default/ctest-first.log | grep -E 'FAILED:|^FAILED ' || true
  done >"$second_tries"
fi
scripts/build.sh asan
ctest --preset asan -j "$jobs" --timeout 900 -L 'unit|validation'
# The integration suite (in-process Fast DDS, every node's app class, the dashboard server,
# DDS Security) under ASan+UBSan: only its test programs are built.
scripts/build.sh asan-dds integration_test_channel_over_dds integration_test_conversions \
  integration_test_dds_roundtrip integration_test_dashboard_server integration_test_estimator_app \
  integration_test_node_apps integration_test_security
ctest --preset asan-dds -j "$jobs" --timeout 900 -L integration
scripts/build.sh fuzz
ctest --preset fuzz -j "$jobs" -L fuzz
if [ -s "$second_tries" ]; then
  echo "=== passed, but these e2e tests needed a second run:"
  cat "$second_tries"
fi
