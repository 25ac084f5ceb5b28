#!/bin/sh
# A WHEP server and a browser script that have no route to each other, only to a real TURN server (coturn's
# turnserver), for the TURN relay test (test_webrtc):
#   unshare -rn sh turn-relay.sh PORT 'SERVER LAUNCH DESCRIPTION' SCRIPT ARGS...
# Inside the network namespace unshare gives (no privileges needed where user namespaces are allowed), the
# server and the browser each get a namespace of their own, joined to this one by a veth pair: the server at
# 10.1.0.2, the browser at 10.2.0.2. This namespace, 10.1.0.1 and 10.2.0.1, does not forward between them:
# what one sends the other never gets, as behind two NATs that map no port. It runs the TURN server on
# 10.1.0.1:3478 (user alice, password s3cret), which both reach, and passes the page's HTTP from 10.2.0.1:PORT
# to the server (a TCP relay in node), so signalling works and media can only go through the TURN server.
# The server (gst-launch-1.0 -m) must be set to use turn://alice:s3cret@10.1.0.1:3478; the script gets the
# base URL http://10.2.0.1:PORT. Exits 77 when something needed is missing.
port=$1 server=$2 script=$3
shift 3
command -v turnserver >/dev/null || { echo "needs turnserver (coturn)"; exit 77; }
command -v nsenter >/dev/null || { echo "needs nsenter (util-linux)"; exit 77; }
dir=$(mktemp -d)
pids=""
cleanup() {
  # shellcheck disable=SC2086
  [ -n "$pids" ] && kill $pids 2>/dev/null
  wait 2>/dev/null
  rm -rf "$dir"
}
trap cleanup EXIT
# A network namespace held open by a sleeping process; prints its pid once it exists ("failed" when it
# cannot be made: the reader is never left waiting).
hold_namespace() {
  mkfifo "$dir/$1"
  { unshare -n sh -c 'echo $$ > "$0"; exec sleep 3600' "$dir/$1" || echo failed > "$dir/$1"; } > /dev/null 2>&1 &
  read -r holder < "$dir/$1"
  # Read once: when cleanup later kills the holder, unshare fails and the "failed" goes to a plain file, not
  # to a FIFO nobody reads any more (the writer would wait for a reader for ever, left behind by the test).
  rm -f "$dir/$1"
  echo "$holder"
}
in_namespace() {
  pid=$1
  shift
  nsenter -t "$pid" -n "$@"
}
ip link set lo up 2>/dev/null || { echo "cannot set up a network namespace (ip, unshare -rn)"; exit 77; }
server_ns=$(hold_namespace server) browser_ns=$(hold_namespace browser)
case "$server_ns $browser_ns" in
  *failed*) echo "cannot make a network namespace inside this one (unshare -n)"; exit 77 ;;
esac
pids="$server_ns $browser_ns"
# The veth ends get no IPv6 link-local address: one that turns valid a moment later is a network change to
# Chromium (see slow-link.sh).
{ ip link add t1 type veth peer name a1 netns "$server_ns" && ip link add t2 type veth peer name b1 netns "$browser_ns" &&
  ip link set t1 addrgenmode none && ip link set t2 addrgenmode none &&
  ip addr add 10.1.0.1/24 dev t1 && ip link set t1 up && ip addr add 10.2.0.1/24 dev t2 && ip link set t2 up &&
  in_namespace "$server_ns" sh -c 'ip link set lo up && ip link set a1 addrgenmode none &&
    ip addr add 10.1.0.2/24 dev a1 && ip link set a1 up && ip route add default via 10.1.0.1' &&
  in_namespace "$browser_ns" sh -c 'ip link set lo up && ip link set b1 addrgenmode none &&
    ip addr add 10.2.0.2/24 dev b1 && ip link set b1 up && ip route add default via 10.2.0.1'; } 2>"$dir/setup.log" ||
  { echo "cannot join network namespaces with veth pairs (ip, nsenter):"; cat "$dir/setup.log"; exit 77; }
turnserver -n --listening-ip=10.1.0.1 --relay-ip=10.1.0.1 --listening-port=3478 --min-port=49152 --max-port=49300 \
  --lt-cred-mech --user=alice:s3cret --realm=vclassroom --no-tls --no-dtls --no-cli --simple-log \
  --pidfile="$dir/turn.pid" --db="$dir/turn.db" --log-file=stdout > "$dir/turn.log" 2>&1 &
pids="$pids $!"
# Its listeners are up once it counts its servers (at most 10 s; a poll of its log, not a fixed wait).
tries=0
until grep -q "Total General servers" "$dir/turn.log" 2>/dev/null; do
  tries=$((tries + 1))
  [ "$tries" -gt 100 ] && { echo "turnserver did not start:"; cat "$dir/turn.log"; exit 1; }
  sleep 0.1
done
# The HTTP relay opens once the server answers, so the page's first requests meet a closed port (which the
# script retries), never a connection cut behind an open one.
node -e '
  const net = require("net");
  const [listen, port, to] = process.argv.slice(1);
  const open = () => net.createServer(c => {
    const s = net.connect(Number(port), to);
    c.pipe(s).pipe(c);
    c.on("error", () => s.destroy());
    s.on("error", () => c.destroy());
  }).listen(Number(port), listen, () => console.log("relaying"));
  const probe = () => {
    const t = net.connect(Number(port), to, () => { t.destroy(); open(); });
    t.on("error", () => setTimeout(probe, 100));  // the server is still starting: poll again
  };
  probe();' 10.2.0.1 "$port" 10.1.0.2 > "$dir/http.log" 2>&1 &
pids="$pids $!"
# nsenter itself, not a subshell around it, runs in the background: it becomes the server, and killing its
# pid stops the server.
# shellcheck disable=SC2086
nsenter -t "$server_ns" -n env ${VCLASSROOM_SERVER_PRELOAD:+LD_PRELOAD=$VCLASSROOM_SERVER_PRELOAD} gst-launch-1.0 -m $server \
  > "$dir/server.log" 2>&1 &
pids="$pids $!"
in_namespace "$browser_ns" node "$script" "http://10.2.0.1:$port" "$@"
status=$?
grep -iE "allocation|error" "$dir/turn.log" | head -n 20 | sed 's/^/turnserver: /'
[ -n "${TURN_RELAY_DEBUG:-}" ] && cat "$dir/server.log" "$dir/http.log" 
exit $status
