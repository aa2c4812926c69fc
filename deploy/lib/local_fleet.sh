# Sourced by deploy/run_multiprocess.sh and deploy/bench_fleet.sh: the loopback transport and a fresh key per
# robot with the configs of a server and its robots.

# use_loopback_transport lcm|dds REPO: sets `url` (LCM multicast with ttl 0, or DDS) and, for DDS, exports
# CYCLONEDDS_URI as the loopback-only configuration (never Cyclone's default, which uses every interface).
use_loopback_transport() {
  if [ "$1" = lcm ]; then
    url='udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608'
  else
    url='dds://?domain=0'
    export CYCLONEDDS_URI="file://$2/deploy/dds/cyclonedds-loopback.xml"
  fi
}

# write_keys_and_configs OUT URL PREFIX N: robots PREFIX0..PREFIX(N-1); writes OUT/keys/<R>.key (mode 600),
# OUT/keys/server_keys.txt, OUT/client_<R>.yaml and OUT/server.yaml (map_dir OUT/map); sets the array `ids`
# and `robot_list` (comma-separated).
write_keys_and_configs() {
  local out="$1" url="$2" prefix="$3" n="$4" i r key
  mkdir -p "$out/keys"
  chmod 700 "$out/keys"
  : >"$out/keys/server_keys.txt"
  ids=()
  for i in $(seq 0 $((n - 1))); do
    r="$prefix$i"; ids+=("$r")
    key=$(od -An -tx1 -N32 /dev/urandom | tr -d ' \n')
    echo "$key" >"$out/keys/$r.key"
    echo "$r $key" >>"$out/keys/server_keys.txt"
    printf 'robot:\n  id: %s\n  key_file: keys/%s.key\ntransport:\n  url: "%s"\n' "$r" "$r" "$url" >"$out/client_$r.yaml"
  done
  chmod 600 "$out/keys/"*
  robot_list=$(IFS=,; echo "${ids[*]}")
  printf 'server:\n  map_dir: %s\n  robots: "%s"\n  transport: "%s"\n  keys_file: %s\n' \
    "$out/map" "$robot_list" "$url" "$out/keys/server_keys.txt" >"$out/server.yaml"
}
