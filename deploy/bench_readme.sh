#!/usr/bin/env bash
# Re-measures the numbers the README quotes, one benchmark after another on one core (taskset -c 1), and
# keeps every program's full output in OUT/<name>.txt. Run it on a quiet machine; CPU times are the numbers
# that survive load, wall times do not. Real-data rows need ../shared/data (skipped with a message without).
# Usage: bash deploy/bench_readme.sh [--out DIR] [--quick]   (--quick: skip the multi-process deployment run)
# Takes ~15 min (~5 min with --quick) on this machine class.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
out=$root/out/bench_readme
quick=0
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --quick) quick=1; shift ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    *) echo "bench_readme: unknown argument $1" >&2; exit 2 ;;
  esac
done
"$root/deploy/build.sh"
bin=$root/build/bin
data=$root/../shared/data
rpy=$data/tum_fr1_rpy_first250
mkdir -p "$out"
core="taskset -c 1"
command -v taskset >/dev/null || core=""

step() {  # step NAME COMMAND...: runs it, keeps its output, says how long it took
  local name=$1; shift
  local t0=$SECONDS
  if "$@" >"$out/$name.txt" 2>&1; then
    echo "bench_readme: $name done in $((SECONDS - t0)) s -> $out/$name.txt"
  else
    echo "bench_readme: $name FAILED (exit $?) -> $out/$name.txt" >&2
    failed=1
  fi
}
failed=0

step codec $core "$bin/bench_codec"
step proto $core "$bin/bench_proto"
step pose_graph $core "$bin/bench_pose_graph"
step map_store $core "$bin/bench_map_store"
step transport bash "$root/deploy/bench_transport.sh"
step synthetic_run $core "$bin/rgbdmap" run --out "$out/run_synthetic"
if [ -d "$rpy" ]; then
  step odometry $core "$bin/bench_odometry"
  step depth_scale $core "$bin/bench_depth_scale"
  step occupancy $core "$bin/bench_occupancy"
  step loop_closure $core "$bin/bench_loop_closure"
  step map_server $core "$bin/bench_map_server"
  step rpy_run $core "$bin/rgbdmap" run --dataset "$rpy" --out "$out/run_rpy"
  step rpy_run_2robots $core "$bin/rgbdmap" run --dataset "$rpy" --robots 2 --out "$out/run_rpy2"
else
  echo "bench_readme: $rpy absent: real-data benchmarks skipped" >&2
fi
step server_tests "$bin/test_map_server" --gtest_filter='*Reduces*:*TwoRobots*:*Restart*:*False*'
if [ "$quick" = 0 ]; then
  step deployment bash "$root/deploy/bench.sh" --out "$out/deployment"
fi
if command -v jq >/dev/null; then
  for r in run_synthetic run_rpy run_rpy2; do
    [ -f "$out/$r/report.json" ] || continue
    echo "$r: $(jq -c '{joint_ate: .server.joint_ate_rmse_m, loops: .server.loops_accepted, robots: [.robots | to_entries[] | {id: .key, ate: .value.ate_rmse_m, odo: .value.ate_rmse_odometry_only_m, kf: .value.keyframes, ms: .value.client_ms_per_frame_median, bytes_kf: .value.bytes_per_keyframe_mean}]}' "$out/$r/report.json" 2>/dev/null || echo '(report not readable)')"
  done
fi
exit $failed
