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

# `import netkf` in Debian's python3 from any folder (docs/python.md, "The core in Python"): a
# .pth file in the user's site-packages naming this checkout's python/, as `pip install --user -e`
# would. Written only when absent or written here before (its first line says so), and only when
# it would change; NETKF_NO_PTH=1 skips it.
if [ "$preset" = default ] && [ -z "${NETKF_NO_PTH:-}" ] && [ -x /usr/bin/python3 ]; then
  site=$(/usr/bin/python3 -m site --user-site 2>/dev/null || true)
  pth="$site/netkf-checkout.pth"
  marker="# netkf: this checkout's python/ (written by scripts/build.sh)"
  want=$(printf '%s\n%s' "$marker" "$PWD/python")
  if [ -n "$site" ] && { [ ! -e "$pth" ] || [ "$(head -n 1 "$pth")" = "$marker" ]; } && [ "$(cat "$pth" 2>/dev/null)" != "$want" ]; then
    mkdir -p "$site" && printf '%s\n' "$want" > "$pth" && echo "netkf: python3 imports netkf from $PWD/python ($pth)" >&2
  fi
fi
