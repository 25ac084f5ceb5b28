#!/usr/bin/env bash
# One command to a lesson on this machine: the synthetic classroom's three cameras (classroom.sh, each a
# process of its own, as on their own machines) and the server (server.sh with a view of their own for each
# lecturer in a browser, LECTURER_OUT=whep-views), joined over loopback. Prints the URL the lecturer opens;
# Ctrl-C ends them all. With real cameras the same two scripts run on their own machines
# (docs/real-classroom.md, step 5).
# Variables: TOKEN (the join secret; default a new random one, printed in the URL), WHEP_PORT (default 8080),
#   CAMERAS (ids, default "0 1 2"), CAMERA_PORTS (the cameras' UDP ports in CAMERAS order, default 5000 + id),
#   CLASSROOM_SOUND (the sound the lecturers hear: a GStreamer audio source, e.g. autoaudiosrc; default a tick a
#   second, the synthetic classroom's; empty: none), CLASSROOM_SPEAKER (where the lecturers' voices play:
#   default autoaudiosink where this machine has sound, else none, said at the start; empty: none),
#   and whatever else server.sh takes (MODEL, WHEP_SESSIONS, WHEP_TLS_CERT, ...; its header lists them).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
here=$(cd "$(dirname "$0")" && pwd)
CAMERAS=${CAMERAS:-"0 1 2"}
read -r -a camera_ids <<< "$CAMERAS"
CAMERA_PORTS=${CAMERA_PORTS:-$(for k in "${camera_ids[@]}"; do printf '%s ' $((5000 + k)); done)}
read -r -a camera_ports <<< "$CAMERA_PORTS"
if [ "${#camera_ports[@]}" -ne "${#camera_ids[@]}" ]; then
  echo "lesson.sh: CAMERA_PORTS needs one port per camera of CAMERAS (${#camera_ids[@]})" >&2
  exit 2
fi
TOKEN=${TOKEN:-$(head -c 18 /dev/urandom | base64 | tr '+/' '-_')}
export TOKEN

# shellcheck source=pipelines/launch.sh
. "$here/launch.sh"

camera_pids=()
server_pid=""
# shellcheck disable=SC2317  # run by the trap
stop_all() {
  trap - INT TERM EXIT
  # The server is a script (SIGTERM); each camera's script is gst-launch-1.0 itself (SIGINT: end-of-stream,
  # so a RECORD= recording is closed properly).
  end_processes "$server_pid" "${camera_pids[*]}"
}
trap stop_all EXIT
trap 'stop_all; exit 130' INT TERM

for i in "${!camera_ids[@]}"; do
  CAMERA=${camera_ids[$i]} PORT=${camera_ports[$i]} "$here/classroom.sh" &
  camera_pids+=($!)
done
# The synthetic classroom's sound, a tick a second, unless CLASSROOM_SOUND names a microphone; the lecturers'
# voices on this machine's loudspeaker where it has one (a sound server's socket or an ALSA device).
if [ -z "${CLASSROOM_SPEAKER+set}" ]; then
  if [ -S "${XDG_RUNTIME_DIR:-/nonexistent}/pulse/native" ] || [ -n "${PULSE_SERVER:-}" ] ||
     ls /dev/snd/pcmC*p > /dev/null 2>&1; then
    CLASSROOM_SPEAKER=autoaudiosink
  else
    CLASSROOM_SPEAKER=""
    echo "lesson.sh: no loudspeaker on this machine: the lecturers' voices are not played (CLASSROOM_SPEAKER)" >&2
  fi
fi
CLASSROOM_SPEAKER=$CLASSROOM_SPEAKER \
CLASSROOM_SOUND=${CLASSROOM_SOUND-audiotestsrc is-live=true wave=ticks volume=0.3} \
LECTURER_OUT=${LECTURER_OUT:-whep-views} CAMERAS="$CAMERAS" CAMERA_PORTS="$CAMERA_PORTS" "$here/server.sh" &
server_pid=$!
echo "lesson.sh: cameras ${CAMERAS} and the server started; on this machine the lecturer opens" \
     "http${WHEP_TLS_CERT:+s}://localhost:${WHEP_PORT:-8080}/?token=$TOKEN (Ctrl-C ends the lesson)"
# The lesson lasts as long as every part of it does: the first to end (an error) ends the others.
status=0
wait -n "$server_pid" "${camera_pids[@]}" || status=$?
echo "lesson.sh: a part of the lesson ended (status $status): stopping the others" >&2
exit "$status"
