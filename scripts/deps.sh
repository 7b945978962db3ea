#!/usr/bin/env bash
# Install the Debian 12 packages netkf needs, only those that are missing
# (fast no-op when everything is there).
set -euo pipefail
packages=(
  build-essential cmake ninja-build ccache pkg-config
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools
  libeigen3-dev libboost-dev libboost-system-dev libspdlog-dev
  libyaml-cpp-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libsdp-dev gnuplot-nox python3-numpy
  iproute2 util-linux tcpdump procps
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
