#!/usr/bin/env bash
# Runs a command (a network transport test or benchmark) inside a private network namespace that has only
# loopback, with multicast routed to lo, so LCM udpm:// and Cyclone DDS traffic can never leave the host.
# Exits 77 (CTest SKIP_RETURN_CODE) when network namespaces are not permitted (non-root CI).
set -u
if [ "$#" -lt 1 ]; then
  echo "usage: $0 COMMAND [ARGS...]" >&2
  exit 2
fi
if ! command -v ip >/dev/null 2>&1 || ! unshare -n true 2>/dev/null; then
  echo "SKIP: 'unshare -n' is not permitted here (needs root or CAP_SYS_ADMIN, and iproute2);"
  echo "      the udpm:// and dds:// network tests did not run."
  exit 77
fi
exec unshare -n bash -c '
  set -e
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo
  export RGBDMAP_TRANSPORT_NETNS=1
  exec "$@"' run_in_netns "$@"
