#!/usr/bin/env bash
# The three worlds on one machine, joined by UDP on loopback: the server, the lecturer (a window, or
# SINK) and one classroom process per camera. Ctrl-C stops everything.
# Variables: those of classroom.sh, server.sh and lecturer.sh (MODEL, RIG, SLIDERS, POSE_TRACE, SINK, ...),
#   CAMERAS (default "0 1 2"), SECONDS_TO_RUN (stop by itself after that many seconds; default: until Ctrl-C),
#   MTU (default 65000: loopback carries 64 KiB packets, ~45 times fewer than Ethernet's 1400 bytes).
# Run it inside `meson devenv -C build` (or after `meson install`) so GStreamer finds the plugins.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
export CAMERAS=${CAMERAS:-"0 1 2"}
export MTU=${MTU:-65000}
pids=()
stop() {
  for p in "${pids[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap stop EXIT INT TERM
"$here/server.sh" & pids+=($!)
"$here/lecturer.sh" & pids+=($!)
for k in $CAMERAS; do CAMERA=$k "$here/classroom.sh" & pids+=($!); done
if [ -n "${SECONDS_TO_RUN:-}" ]; then sleep "$SECONDS_TO_RUN"; else wait; fi
