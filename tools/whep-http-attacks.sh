#!/usr/bin/env bash
# Tries the WHEP HTTP server's limits (issue #29 item 3, docs/reliability.md) against a server of its own
# on this machine: whepserversink fed by videotestsrc, started here under gst-launch-1.0 with at most
# 1024 descriptors (the common default), on 127.0.0.1/::1 port PORT. Every attack goes to 127.0.0.1 or ::1
# only, bounded in count and time:
#  1. big-body: 4 POSTs without the token, each announcing and sending up to 400 MiB (curl, 30 s each at
#     most, in parallel); the server's RSS (VmRSS) before and after, and its peak (VmHWM);
#  2. idle: 1100 connections opened and left idle (bash /dev/tcp), the server's open descriptors just after
#     and once they are closed by the client; then whether IPv4 and IPv6 are still served;
#  3. bad-pt: offers naming H.264 on payload types 200 and 99999; their HTTP status, whether the server
#     is still running, and the errors in its log.
# Run inside `meson devenv -C build` (or with GST_PLUGIN_PATH set) so that gst-launch-1.0 finds the plugin.
# Prints one line per measure. Needs curl.
set -euo pipefail

port=18480
usage="usage: tools/whep-http-attacks.sh [--port N] (inside meson devenv -C build)"
while [ $# -gt 0 ]; do
  case "$1" in
    --port) port="${2:?$usage}"; shift 2 ;;
    -h|--help) echo "$usage"; exit 0 ;;
    *) echo "$usage" >&2; exit 2 ;;
  esac
done
case "$port" in ''|*[!0-9]*) echo "whep-http-attacks: --port needs a number" >&2; exit 2 ;; esac
command -v curl >/dev/null || { echo "whep-http-attacks: curl is missing" >&2; exit 2; }

token=attack-test-token
log=$(mktemp)
( ulimit -n 1024; exec gst-launch-1.0 videotestsrc is-live=true ! video/x-raw,width=320,height=180 ! \
    whepserversink port="$port" token="$token" >"$log" 2>&1 ) &
server=$!
trap 'kill $server 2>/dev/null || true; wait $server 2>/dev/null || true; rm -f "$log"' EXIT
rss() { awk -v k="$1:" '$1 == k { print int($2 / 1024) }' "/proc/$server/status"; }
fds() { ls "/proc/$server/fd" | wc -l; }
code() { curl -s -o /dev/null -w '%{http_code}' --max-time 10 "$@" || true; }

# Ready when it answers (a 401 without the token).
for _ in $(seq 100); do
  [ "$(code "http://127.0.0.1:$port/")" = 401 ] && break
  kill -0 $server 2>/dev/null || { cat "$log"; exit 1; }
  sleep 0.1
done
echo "server pid $server on port $port, RSS $(rss VmRSS) MiB, $(fds) descriptors"

# 1. big-body
before=$(rss VmRSS)
start=$(date +%s.%N)
pids=()
for i in 1 2 3 4; do
  head -c 400M /dev/zero | curl -s -o /dev/null -w '%{http_code} %{size_upload}' --max-time 30 \
    -H 'Content-Type: application/sdp' -H 'Content-Length: 419430400' -H 'Expect:' \
    --data-binary @- "http://127.0.0.1:$port/whep" >"$log.big$i" 2>/dev/null &
  pids+=($!)
done
wait "${pids[@]}" || true
end=$(date +%s.%N)
for i in 1 2 3 4; do echo "big-body: POST $i: status, bytes sent: $(cat "$log.big$i")"; rm -f "$log.big$i"; done
echo "big-body: RSS before $before MiB, after $(rss VmRSS) MiB, peak $(rss VmHWM) MiB," \
     "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }') s"

# 2. idle
ulimit -n 4096
opened=0
for _ in $(seq 1100); do
  exec {fd}<>/dev/tcp/127.0.0.1/$port 2>/dev/null || break
  opened=$((opened + 1))
  eval "idle_$opened=$fd"
done
echo "idle: $opened connections opened, the server holds $(fds) descriptors"
for i in $(seq $opened); do eval "exec {idle_$i}>&-"; done
echo "idle: after they closed: IPv4 $(code "http://127.0.0.1:$port/"), IPv6 $(code -g "http://[::1]:$port/")," \
     "the server holds $(fds) descriptors"

# 3. bad-pt
fp=$(printf 'A5:%.0s' $(seq 31))A5
for pt in 200 99999; do
  offer="v=0\r\no=- 1 2 IN IP4 127.0.0.1\r\ns=-\r\nt=0 0\r\nm=video 9 UDP/TLS/RTP/SAVPF $pt\r\nc=IN IP4 0.0.0.0\r\n"
  offer+="a=ice-ufrag:bad\r\na=ice-pwd:badpeertestpassword00000\r\na=fingerprint:sha-256 $fp\r\na=setup:actpass\r\n"
  offer+="a=mid:0\r\na=recvonly\r\na=rtcp-mux\r\na=rtpmap:$pt H264/90000\r\n"
  offer+="a=fmtp:$pt level-asymmetry-allowed=1;packetization-mode=1;profile-level-id=42e01f\r\n"
  status=$(printf "$offer" | code -H 'Content-Type: application/sdp' --data-binary @- \
           "http://127.0.0.1:$port/whep?token=$token")
  echo "bad-pt $pt: status $status"
done
sleep 2  # lets an error the offers caused reach the log (a report, not a synchronisation)
if kill -0 $server 2>/dev/null; then running=yes; else running=no; fi
echo "bad-pt: server still running: $running; ERROR lines in its log: $(grep -c ERROR "$log" || true)"
grep -m3 ERROR "$log" | sed 's/^/  /' || true
