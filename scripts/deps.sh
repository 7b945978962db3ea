#!/usr/bin/env bash
# Install the Debian 12 packages netkf needs, only those that are missing
# (fast no-op when everything is there), then the page's npm packages from
# package-lock.json (npm ci, again only when the lockfile changed).
set -euo pipefail
packages=(
  build-essential cmake ninja-build ccache pkg-config
  clang-14 libclang-rt-14-dev
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libeigen3-dev libboost-dev libboost-system-dev libspdlog-dev
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libsdp-dev gnuplot-nox python3-numpy python3-yaml python3-pandas python3-pytest
  python3-zstandard python3-lz4 python3-dev pybind11-dev python3-statsmodels
  iproute2 util-linux tcpdump procps openssl
  prometheus-cpp-dev prometheus chromium
  cyclonedds-dev cyclonedds-tools systemd
)
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "netkf: installing ${missing[*]}" >&2
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# Node.js with its bundled npm: Debian's nodejs package when no node is installed (never
# Debian's separate npm package, which conflicts with it).
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "netkf: installing nodejs" >&2
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  "${sudo_cmd[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends nodejs
fi

# The dashboard's uPlot (embedded at build time) and the tests' browser driver and
# Foxglove client, exactly as locked.
cd "$(dirname "$0")/.."
lock_hash=$(sha256sum package-lock.json | cut -d' ' -f1)
if [ "$(cat node_modules/.netkf-lock-hash 2>/dev/null)" != "$lock_hash" ]; then
  echo "netkf: npm ci" >&2
  npm ci --no-audit --no-fund --loglevel=error
  echo "$lock_hash" > node_modules/.netkf-lock-hash
fi
