#!/bin/sh
# A WHEP server and a browser script behind a slow link, for the lecturer's bitrate test (test_webrtc):
#   unshare -rn sh slow-link.sh KBIT PORT 'SERVER LAUNCH DESCRIPTION' SCRIPT ARGS...
# In a network namespace of its own (unshare -rn: no privileges needed where user namespaces are allowed),
# loopback is limited to KBIT kbit/s by a token bucket (tc tbf), so server and browser talk over a real slow
# link. The server runs as gst-launch-1.0 -m; its vclassroom-lecturer-bitrate messages are printed as
# "server: ..." lines after the script's output. Exits 77 when the namespace or the token bucket cannot be
# set up (the test then skips).
kbit=$1 port=$2 server=$3 script=$4
shift 4
# Loopback with an Ethernet MTU (the token bucket drops any packet larger than its burst). WebRTC gathers
# no loopback candidates: a veth pair gives both ends an address, and traffic between the
# namespace's own addresses still goes through loopback. The veth ends get no IPv6 link-local address: one
# that turns valid a moment later (duplicate address detection) is a network change to Chromium, which then
# fails the requests under way (ERR_NETWORK_CHANGED), the page's join among them.
{ ip link set lo up mtu 1500 && ip link add vc0 type veth peer name vc1 && ip link set vc0 addrgenmode none &&
  ip link set vc1 addrgenmode none && ip addr add 10.201.0.1/24 dev vc0 && ip link set vc0 up &&
  ip link set vc1 up; } 2>/dev/null ||
  { echo "cannot set up a network namespace with a veth pair (ip, unshare -rn)"; exit 77; }
tc qdisc add dev lo root tbf rate "${kbit}kbit" burst 16kb latency 250ms 2>/dev/null ||
  { echo "cannot limit loopback with tc tbf"; exit 77; }
log=$(mktemp)
# The description is one argument; gst-launch-1.0 takes it split into words, as a shell would.
# shellcheck disable=SC2086
env ${VCLASSROOM_SERVER_PRELOAD:+LD_PRELOAD=$VCLASSROOM_SERVER_PRELOAD} gst-launch-1.0 -m $server > "$log" 2>&1 &
pid=$!
node "$script" "http://127.0.0.1:$port" "$@"
status=$?
kill "$pid"
wait "$pid"
grep -o 'vclassroom-lecturer-bitrate.*' "$log" | sed 's/^/server: /'
rm -f "$log"
exit $status
