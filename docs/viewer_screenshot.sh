#!/usr/bin/env bash
# The README's viewer screenshot, docs/viewer.png: the README's race served in rerun's web
# viewer (127.0.0.1 only), shot by headless Chromium at 1600 x 1000 (Debian 12's chromium 156
# took the current one on the 2-vCPU development VM, 2026-11-27, about 30 s a try). What the
# viewer shows depends on when the shot falls (its side panel open or not, the plots drawn).
#
#   bash docs/viewer_screenshot.sh [OUT.png]      # from the repository root; needs chromium
#
# The race is served for 120 s; the viewer server stops with the race command, so nothing is
# left holding the ports (the trap also stops the race if this script is interrupted).
set -euo pipefail
out="${1:-docs/viewer.png}"
browser="$(command -v chromium || command -v chromium-browser || command -v google-chrome || true)"
if [ -z "$browser" ]; then
    echo "viewer_screenshot.sh: no chromium found; install it (Debian: apt-get install chromium)" >&2
    exit 2
fi
h2h-racing race --track speedway --drivers racing_line,pure_pursuit --serve \
    --serve-seconds 120 --no-progress > /dev/null &
race=$!
trap 'kill "$race" 2>/dev/null || true' EXIT
sleep 20  # the race runs (a few seconds) and the web viewer starts serving it
# The URL race --serve prints: the viewer on port 9090 reading the race's gRPC proxy on 9876.
# WebGL through SwiftShader (no GPU: the viewer shows "Software rasterizer"); the virtual time
# lets the viewer load the race before the shot. On a busy machine the shot is sometimes taken
# before the viewer has loaded the race (a near-empty PNG of 10-30 KB; the viewer with the
# race is about 190 KB): then it is taken again, up to 4 times.
for attempt in 1 2 3 4; do
    "$browser" --headless=new --no-sandbox --hide-scrollbars --use-angle=swiftshader \
        --enable-unsafe-swiftshader --window-size=1600,1000 --virtual-time-budget=60000 \
        --timeout=90000 --screenshot="$out" \
        "http://127.0.0.1:9090/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A9876%2Fproxy" 2> /dev/null
    if [ "$(stat -c %s "$out")" -gt 100000 ]; then
        break
    fi
    echo "attempt $attempt: the viewer had not loaded the race yet; again" >&2
done
echo "screenshot -> $out"
