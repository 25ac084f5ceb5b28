#!/usr/bin/env bash
# Classroom side, one camera: source -> rgbdenc -> RTP -> UDP to the server.
# Variables: CAMERA (id, default 0), SERVER (host, default 127.0.0.1), PORT (default 5000 + CAMERA),
#   SOURCE (default: the synthetic classroom's camera CAMERA, live), QUALITY (JPEG, default 90),
#   DROP (share of packets to drop on purpose, to test a bad link; default 0).
set -euo pipefail
CAMERA=${CAMERA:-0}
SERVER=${SERVER:-127.0.0.1}
PORT=${PORT:-$((5000 + CAMERA))}
QUALITY=${QUALITY:-90}
DROP=${DROP:-0}
SOURCE=${SOURCE:-"rgbdtestsrc camera-id=$CAMERA is-live=true ground-truth=false"}
exec gst-launch-1.0 -e $SOURCE ! rgbdenc quality=$QUALITY ! rtpgstpay config-interval=1 mtu=1400 ! \
  identity drop-probability=$DROP ! udpsink host=$SERVER port=$PORT sync=false
