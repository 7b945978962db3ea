#!/usr/bin/env bash
# Configure (once) and build a preset: scripts/build.sh [default|asan|fuzz] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
preset=${1:-default}
# ccache: paths under the checkout are hashed relative to it, and the working directory
# not at all, so a fresh clone (as CI makes) hits the cache of an earlier one.
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=true
# Configured again when the presets changed since (their cache variables apply only then).
if [ ! -f "build/$preset/build.ninja" ] || [ CMakePresets.json -nt "build/$preset/CMakeCache.txt" ]; then
  cmake --preset "$preset" >/dev/null
fi
shift || true
if [ $# -gt 0 ]; then
  cmake --build --preset "$preset" --target "$@"
else
  cmake --build --preset "$preset"
fi
