#!/usr/bin/env bash
# Classroom side, one camera: source -> rgbdenc -> RTP -> UDP to the server.
# Variables: CAMERA (id, default 0), SERVER (host, default 127.0.0.1), PORT (default 5000 + CAMERA),
#   SOURCE (default: the synthetic classroom's camera CAMERA, live), QUALITY (JPEG, default 90),
#   DROP (share of packets to drop on purpose, to test a bad link; default 0).
#   STATS (0: quiet; N: every N frames rgbdenc posts vclassroom-codec-stats, printed by -m),
#   MTU (largest RTP packet, default 1400 for an Ethernet link; a jumbo-frame LAN takes about 9000,
#   loopback up to 65000; the server's MTU must be as large).
set -euo pipefail
CAMERA=${CAMERA:-0}
SERVER=${SERVER:-127.0.0.1}
PORT=${PORT:-$((5000 + CAMERA))}
QUALITY=${QUALITY:-90}
DROP=${DROP:-0}
STATS=${STATS:-0}
MTU=${MTU:-1400}
if ! [[ $MTU =~ ^[0-9]+$ ]] || [ "$MTU" -lt 200 ] || [ "$MTU" -gt 65000 ]; then
  echo "classroom.sh: MTU must be a packet size in bytes, 200 to 65000 (got '$MTU')" >&2
  exit 2
fi
SOURCE=${SOURCE:-"rgbdtestsrc camera-id=$CAMERA is-live=true ground-truth=false"}
# STATS > 0: every STATS frames the encoder posts what it sent (printed by -m).
verbose=""
[ "$STATS" -gt 0 ] && verbose="-m"
exec gst-launch-1.0 -e $verbose $SOURCE ! rgbdenc name=enc quality=$QUALITY stats-interval=$STATS ! rtpgstpay config-interval=1 mtu=$MTU ! \
  identity drop-probability=$DROP ! udpsink host=$SERVER port=$PORT sync=false
