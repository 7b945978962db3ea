#!/usr/bin/env bash
# Quick start 2: install what is missing, build, and run every test: the full suite
# (unit, validation, integration, e2e) on the normal build, then the DDS-free suites
# (unit, validation) again under ASan+UBSan, then a short
# run of each libFuzzer target on its seed corpus (clang-14, tests/fuzz).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
jobs=$(nproc)
scripts/build.sh default
ctest --preset default -j "$jobs" --timeout 600
scripts/build.sh asan
ctest --preset asan -j "$jobs" --timeout 900 -L 'unit|validation'
scripts/build.sh fuzz
ctest --preset fuzz -j "$jobs" -L fuzz
