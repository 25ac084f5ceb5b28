# Sourced by the pipeline scripts: run_launch runs gst-launch-1.0 so that Ctrl-C (SIGINT) or SIGTERM
# always ends it (a script started in the background of another, as loopback.sh does, ignores SIGINT:
# stop it with SIGTERM). It is asked to finish first (gst-launch-1.0 -e sends end-of-stream), and killed
# when it has not ended STOP_GRACE seconds later: an input that never received a packet (a camera that
# never came, behind rtpssrcdemux) holds the end-of-stream back for ever.
STOP_GRACE=${STOP_GRACE:-5}
if ! [[ $STOP_GRACE =~ ^[0-9]+$ ]]; then
  echo "STOP_GRACE must be a number of seconds (got '$STOP_GRACE')" >&2
  exit 2
fi
launch_pid=""
launch_killer=""

stop_launch() {
  [ -n "$launch_pid" ] || exit 130
  kill -INT "$launch_pid" 2>/dev/null || true
  if [ -z "$launch_killer" ]; then
    (sleep "$STOP_GRACE"; kill -KILL "$launch_pid" 2>/dev/null) >/dev/null 2>&1 &
    launch_killer=$!
  fi
}

run_launch() {
  local rc
  trap stop_launch INT TERM
  gst-launch-1.0 "$@" &
  launch_pid=$!
  while true; do
    rc=0
    wait "$launch_pid" || rc=$?  # (the scripts run with set -e)
    kill -0 "$launch_pid" 2>/dev/null || break  # a signal ended the wait, not gst-launch-1.0: wait again
  done
  [ -z "$launch_killer" ] || kill "$launch_killer" 2>/dev/null || true
  trap - INT TERM
  return "$rc"
}
