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
command -v python3 >/dev/null 2>&1 || { echo "SKIP: python3 is not installed (deploy/install_deps.sh)"; exit 77; }
source "$(dirname "$0")/../cli/map_test_lib.sh"
tmp=$(mktemp -d)
pid=""
cleanup() { [ -n "$pid" ] && kill -INT "$pid" 2>/dev/null; wait 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
port=18766
"$bin/rgbdmap" run --robots 2 --frames 200 --out "$tmp/out" --viewer "$port" >"$tmp/run.log" 2>&1 &
pid=$!
wait_for_line "$tmp/run.log" "the map stays at" "$pid" || { echo "FAIL: the run did not finish with the viewer open"; tail -20 "$tmp/run.log"; exit 1; }
voxels=$(occupied_voxels "$tmp/out/map.bt")
fail=0
# The page is loaded once and watched in real time (tests/viewer/page_probe.py, the DevTools protocol over a
# pipe) until its title reports both robots' maps drawn, for up to 150 s: on a machine busy with other tests
# the map arrives later, but it must arrive. Then its DOM and a screenshot are taken.
expected_text="rgbdmap viewer: $((2 * voxels)) voxels"
expected="<title>$expected_text</title>"
python3 "$(dirname "$0")/page_probe.py" "http://127.0.0.1:$port/" --title "$expected_text" --timeout 150 \
  --dom "$tmp/dom.html" --screenshot "$tmp/shot.png" --size 1280,800 --chromium-log "$tmp/chromium.log" \
  >"$tmp/probe.out"
probe=$?
[ "$probe" -le 1 ] || { echo "FAIL: chromium did not load the page (page_probe exit $probe)"; cat "$tmp/probe.out";
  tail -5 "$tmp/chromium.log"; exit 1; }
title=$(grep -o '<title>[^<]*</title>' "$tmp/dom.html")
echo "page: $title after ${SECONDS} s; $(grep -o 'data-state="[^"]*"' "$tmp/dom.html")"
# Both robots are in one merged map: each robot's copy holds all of its voxels.
[ "$title" = "$expected" ] && echo "ok: the page drew 2 x $voxels voxels" \
  || { echo "FAIL: page title '$title', expected 2 x $voxels voxels (map.bt)"; fail=1; }
grep -q 'data-state="[^"]* grids [1-9][0-9]* poses [1-9]' "$tmp/dom.html" \
  && echo "ok: the 2-D maps and the robots' poses are drawn" || { echo "FAIL: no 2-D map or pose drawn"; fail=1; }
grep -q '<b>robot0</b>' "$tmp/dom.html" && grep -q '<b>robot1</b>' "$tmp/dom.html" \
  && echo "ok: legend lists both robots" || { echo "FAIL: legend without both robots"; fail=1; }
stats=""
[ -s "$tmp/shot.png" ] && stats=$("$bin/viewer_png_colours" "$tmp/shot.png" f4f4f4 e6194b 3cb44b)
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
