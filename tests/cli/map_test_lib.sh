# Shared by the tests that keep `rgbdmap run` open after its run (--viewer, --ros2) and compare with its map
# files (sourced; needs $bin, the folder of the programs).
wait_for_line() {  # wait_for_line LOG PATTERN PID: until LOG has PATTERN (2 min at most) or PID ended; status
  local _
  for _ in $(seq 1 240); do
    grep -q "$2" "$1" && return 0
    kill -0 "$3" 2>/dev/null || break
    sleep 0.5
  done
  grep -q "$2" "$1"
}
occupied_voxels() {  # occupied_voxels FILE.bt: its occupied voxels at the finest resolution (rgbdmap view-map)
  "$bin/rgbdmap" view-map "$1" | awk '/^resolution_m/ {r = $2} /^occupied_volume_m3/ {v = $2}
    END {printf "%d", v / (r * r * r) + 0.5}'
}
largest_grid() {  # largest_grid DIR: "WIDTH HEIGHT" of the largest map_<id>.pgm in DIR ("0 0" without one)
  local pgm w h best_w=0 best_h=0
  for pgm in "$1"/map_*.pgm; do
    [ -f "$pgm" ] || continue
    read -r w h < <(sed -n 3p "$pgm")
    [ $((w * h)) -gt $((best_w * best_h)) ] && best_w=$w best_h=$h
  done
  echo "$best_w $best_h"
}
