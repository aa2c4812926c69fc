#!/usr/bin/env bash
# The viewer's web page in headless Chromium: rgbdmap run --viewer with two robots (memq://) in the private
# loopback-only namespace; once the run is over and the viewer stays open, Chromium loads
# http://127.0.0.1:PORT/ (three.js from Debian's libjs-three, served by the viewer), the page must report the
# map as drawn (title "rgbdmap viewer: N voxels" with N = map.bt's occupied voxels per robot) and its
# screenshot must show the map (non-background pixels) and both robots' colours (trajectory lines and
# markers). Skips (77) without chromium. Usage: test_viewer_page.sh BIN_DIR [SCREENSHOT_COPY.png]
set -u
bin="$1"
copy="${2:-}"
command -v chromium >/dev/null 2>&1 || { echo "SKIP: chromium is not installed (deploy/install_deps.sh)"; exit 77; }
tmp=$(mktemp -d)
pid=""
cleanup() { [ -n "$pid" ] && kill -INT "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
port=18766
"$bin/rgbdmap" run --robots 2 --frames 200 --out "$tmp/out" --viewer "$port" >"$tmp/run.log" 2>&1 &
pid=$!
for _ in $(seq 1 240); do
  grep -q "the map stays at" "$tmp/run.log" && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.5
done
grep -q "the map stays at" "$tmp/run.log" || { echo "FAIL: the run did not finish with the viewer open"; tail -20 "$tmp/run.log"; exit 1; }
voxels=$("$bin/rgbdmap" view-map "$tmp/out/map.bt" | awk '/^resolution_m/ {r = $2} /^occupied_volume_m3/ {v = $2}
  END {printf "%d", v / (r * r * r) + 0.5}')
chrome() {
  timeout 90 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync --user-data-dir="$tmp/profile" \
    --enable-unsafe-swiftshader --window-size=1280,800 --virtual-time-budget=10000 "$@" \
    "http://127.0.0.1:$port/" 2>>"$tmp/chromium.log"
}
fail=0
# Chromium's virtual time does not wait for WebSocket data: on a busy machine the map may arrive after the
# budget, so the page is loaded up to 4 times until it reports the map drawn.
expected="<title>rgbdmap viewer: $((2 * voxels)) voxels</title>"
for attempt in 1 2 3 4; do
  chrome --dump-dom >"$tmp/dom.html"
  title=$(grep -o '<title>[^<]*</title>' "$tmp/dom.html")
  [ "$title" = "$expected" ] && break
  echo "attempt $attempt: $title"
  [ "$SECONDS" -lt 150 ] || break
done
echo "page: $title; $(grep -o 'data-state="[^"]*"' "$tmp/dom.html")"
# Both robots are in one merged map: each robot's copy holds all of its voxels.
[ "$title" = "$expected" ] && echo "ok: the page drew 2 x $voxels voxels" \
  || { echo "FAIL: page title '$title', expected 2 x $voxels voxels (map.bt)"; fail=1; }
grep -q 'data-state="[^"]* grids [1-9][0-9]* poses [1-9]' "$tmp/dom.html" \
  && echo "ok: the 2-D maps and the robots' poses are drawn" || { echo "FAIL: no 2-D map or pose drawn"; fail=1; }
grep -q '<b>robot0</b>' "$tmp/dom.html" && grep -q '<b>robot1</b>' "$tmp/dom.html" \
  && echo "ok: legend lists both robots" || { echo "FAIL: legend without both robots"; fail=1; }
# A screenshot renders the whole map in software (SwiftShader): on a machine busy with other tests one can
# outlast chromium's 90 s, so a missing screenshot is tried again while the test's 300 s allow it.
stats=""
for attempt in 1 2 3 4; do
  rm -f "$tmp/shot.png"
  chrome --screenshot="$tmp/shot.png" >/dev/null
  rc=$?
  if [ -s "$tmp/shot.png" ]; then
    stats=$("$bin/viewer_png_colours" "$tmp/shot.png" f4f4f4 e6194b 3cb44b)
    [ "$(echo "$stats" | awk '{print $4}')" -ge 50000 ] && break
    echo "attempt $attempt: $stats"
  else
    echo "attempt $attempt: no screenshot (chromium exit $rc after ${SECONDS} s into the test)"
  fi
  [ "$SECONDS" -lt 190 ] || break
done
[ -s "$tmp/shot.png" ] && [ -n "$stats" ] || { echo "FAIL: no screenshot"; tail -5 "$tmp/chromium.log"; exit 1; }
echo "screenshot: $stats"
read -r _ _ _ non_bg _ red _ green <<<"$stats"
[ "$non_bg" -ge 50000 ] && echo "ok: $non_bg non-background pixels" || { echo "FAIL: only $non_bg non-background pixels"; fail=1; }
[ "$red" -ge 30 ] && [ "$green" -ge 30 ] && echo "ok: robot colours present (robot0 $red px, robot1 $green px)" \
  || { echo "FAIL: robot colours missing (robot0 $red px, robot1 $green px)"; fail=1; }
[ -n "$copy" ] && cp "$tmp/shot.png" "$copy"
kill -INT "$pid"
wait "$pid" || { echo "FAIL: rgbdmap run exited $? after Ctrl-C"; fail=1; }
pid=""
[ "$fail" -eq 0 ] && echo "viewer.page: all checks passed"
exit "$fail"
