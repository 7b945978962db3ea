#!/usr/bin/env bash
# Run a command inside a private network namespace with only loopback up and the
# multicast range routed to lo, so no DDS packet can leave this machine.
# Usage: scripts/in-netns.sh COMMAND [ARGS...]
set -euo pipefail
if [ "${NETKF_IN_NETNS:-}" = 1 ]; then exec "$@"; fi
exec unshare -n -- env NETKF_IN_NETNS=1 bash -c '
  ip link set lo up
  ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
  exec "$@"' netns "$@"
