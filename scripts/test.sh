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
ctest --preset default -j "$jobs" --timeout 600
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
