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

# pkill without a preloaded library: under the sanitizer build's tests the scripts run with libasan in
# LD_PRELOAD, and procps' pkill then deadlocks in glibc's textdomain before it does anything.
kill_children() {
  env -u LD_PRELOAD pkill "$@"
}

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
  # The killer is no longer needed: it and its sleep end now.
  if [ -n "$launch_killer" ]; then
    kill_children -P "$launch_killer" 2>/dev/null || true
    kill "$launch_killer" 2>/dev/null || true
  fi
  trap - INT TERM
  return "$rc"
}

# Ends processes this script started in the background: each asked to finish (the pipeline scripts with
# SIGTERM, since a script started in the background ignores SIGINT; gst-launch-1.0 itself with SIGINT, as
# it handles that one and sends end-of-stream), given STOP_GRACE seconds, then killed (a script with the
# processes it started), and reaped.
#   end_processes "<pids of scripts>" "<pids of gst-launch-1.0>"
end_processes() {
  local scripts=$1 launches=$2 p waited=0 alive
  for p in $scripts; do kill -TERM "$p" 2>/dev/null || true; done
  for p in $launches; do kill -INT "$p" 2>/dev/null || true; done
  while [ "$waited" -lt $((STOP_GRACE * 10)) ]; do
    alive=0
    for p in $scripts $launches; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ "$alive" = 0 ] && break
    sleep 0.1  # polling the processes' end, bounded by STOP_GRACE
    waited=$((waited + 1))
  done
  for p in $scripts; do kill_children -KILL -P "$p" 2>/dev/null || true; done
  for p in $scripts $launches; do kill -KILL "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
