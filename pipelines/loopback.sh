#!/usr/bin/env bash
# The three worlds on one machine, joined by UDP on loopback: the server, the lecturer (a window, or
# SINK) and one classroom process per camera. Ctrl-C stops everything; so does any of them ending (the
# server failing to start, say): the others are stopped and the script returns its status.
# Variables: those of classroom.sh, server.sh and lecturer.sh (MODEL, RIG, SLIDERS, POSE_TRACE, SINK, ...),
#   CAMERAS (default "0 1 2"), SECONDS_TO_RUN (stop by itself after that many seconds; default: until Ctrl-C),
#   MTU (default 65000: loopback carries 64 KiB packets, ~45 times fewer than Ethernet's 1400 bytes),
#   PORT_BASE (default 5000): this flow's ports are PORT_BASE + camera id (RTP), + 100 + id (each camera's
#   retransmission requests), PORT_BASE + 10 (video), + 11 (poses) and + 12 (the classroom's sound, with
#   CLASSROOM_SOUND and SPEAKER): a second flow on the same host runs
#   without crosstalk with e.g. PORT_BASE=6000.
#   STOP_GRACE (seconds each process gets to end after Ctrl-C or end-of-stream before it is killed, default 5).
# Runs from the source root, the build folder or installed (pipelines/trees.sh finds the plugins).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
here="$(cd "$(dirname "$0")" && pwd)"
# shellcheck source=pipelines/launch.sh
. "$here/launch.sh"
export CAMERAS=${CAMERAS:-"0 1 2"}
export MTU=${MTU:-65000}
PORT_BASE=${PORT_BASE:-5000}
STOP_GRACE=${STOP_GRACE:-5}
if ! [[ $PORT_BASE =~ ^[0-9]+$ ]] || [ "$PORT_BASE" -lt 1024 ] || [ "$PORT_BASE" -gt 65000 ]; then
  echo "loopback.sh: PORT_BASE must be 1024 to 65000 (got '$PORT_BASE')" >&2
  exit 2
fi
export BASE_PORT=$PORT_BASE VIDEO_PORT=$((PORT_BASE + 10)) POSE_PORT=$((PORT_BASE + 11)) AUDIO_PORT=$((PORT_BASE + 12))
pids=()
stopping=0
# Asks every process still running to end, waits at most STOP_GRACE seconds, then kills what is left: the
# server (first) is a script, the others are gst-launch-1.0 itself (pipelines/launch.sh, end_processes).
stop() {
  [ "$stopping" = 1 ] && return
  stopping=1
  end_processes "${pids[0]}" "${pids[*]:1}"
}
trap stop EXIT
trap 'stop; exit 130' INT TERM
"$here/server.sh" & pids+=($!)
"$here/lecturer.sh" & pids+=($!)
for k in $CAMERAS; do CAMERA=$k PORT=$((PORT_BASE + k)) "$here/classroom.sh" & pids+=($!); done
if [ -n "${SECONDS_TO_RUN:-}" ]; then sleep "$SECONDS_TO_RUN" & pids+=($!); fi
# Whichever ends first (a process, or the timer) ends the flow.
status=0
wait -n || status=$?
stop
exit "$status"
