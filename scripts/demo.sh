#!/usr/bin/env bash
# Quick start 1: install what is missing, build, and run the default scenario live
# on localhost (all DDS traffic on 127.0.0.1, no multicast). Extra arguments go to
# `netkf launch` (e.g. a scenario file, --duration 30, --record run.csv).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/deps.sh
# Only what the demo runs: the CLI and the four nodes (scripts/test.sh builds the rest).
scripts/build.sh default netkf plant_node sensor_node channel_emulator estimator_node
exec build/default/cli/netkf launch "$@"
