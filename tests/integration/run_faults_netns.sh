#!/usr/bin/env bash
# CTest driver of the fault tests (entries faults.<fault>.<transport>, labels netns and faults):
# runs tests/integration/faults.sh FAULT over TRANSPORT with --check (every keyframe sent is stored, one
# merged map, merged ATE below the clean run's 2 cm bound; see faults.sh) on the synthetic 200-frame loop
# that the fixture faults.dataset wrote (one dataset for all: synthesising it takes ~20 s of a core).
# Exit 77 (skip) where 'unshare -n' is not permitted.
# Usage: run_faults_netns.sh BIN_DIR DATASET_DIR FAULT lcm|dds
#        run_faults_netns.sh --dataset BIN_DIR DATASET_DIR      (fixture setup: synthesise it)
#        run_faults_netns.sh --remove-dataset DATASET_DIR       (fixture cleanup)
set -u
repo="$(cd "$(dirname "$0")/../.." && pwd)"
case "${1:-}" in
  --dataset)
    rm -rf "$3"
    "$2/rgbdmap" synth --scene loop --frames 200 --out "$3" >/dev/null 2>&1 || { echo "FAIL: synth"; exit 1; }
    exit 0 ;;
  --remove-dataset) rm -rf "$2"; exit 0 ;;
esac
bin="$1" ds="$2" fault="$3" transport="$4"
if ! command -v ip >/dev/null 2>&1 || ! unshare -n true 2>/dev/null; then
  echo "SKIP: 'unshare -n' is not permitted here (needs root); the fault test did not run."
  exit 77
fi
[ -s "$ds/groundtruth.txt" ] || { echo "FAIL: no dataset in $ds (fixture faults.dataset)"; exit 1; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bash "$repo/tests/integration/faults.sh" --fault "$fault" --transport "$transport" --bin "$bin" --dataset "$ds" \
  --out "$tmp/run" --check 0.02
