#!/usr/bin/env bash
# Classroom side, one camera: source -> H.264 colour with the depth in each access unit (rgbdlinksplit,
# x264enc, rgbdlinkmux) -> rtph264pay, or with LINK=vcrd1 rgbdenc -> rtpgstpay -> UDP to the server, with
# retransmission of lost packets (RFC 4588):
# the server's RTCP NACKs and key frame requests (PLI/FIR, RFC 4585/5104) come back on NACK_PORT, rtprtxsend
# resends and x264enc sends a key frame (docs/network.md, "The H.264 camera link").
# LINK (h264, the default: the camera link above, about 14 Mbit/s at 960x540, its colour 4:2:0, its depth within
#   DEPTH_TOLERANCE (docs/network.md says what that costs); vcrd1: rgbdenc's JPEG + lossless depth through
#   rtpgstpay, about 140 Mbit/s; the server's LINK must match),
# DEPTH_TOLERANCE (h264 link: the largest depth error in mm at 1 m, growing with z^2; default 2.8, just under
#   the depth step a Kinect-class sensor resolves; 0: lossless), BITRATE (h264 link: x264enc kbit/s, default
#   4000), KEY_INTERVAL (h264 link: frames between key frames at most, default 60: 2 s at 30 fps),
# Variables: CAMERA (id, default 0), SERVER (host, default 127.0.0.1), PORT (default 5000 + CAMERA),
#   NACK_PORT (port here for the server's RTCP, i.e. its retransmission requests, default PORT + 100;
#   only packets from SERVER are taken there),
#   SOURCE (default: the synthetic classroom's camera CAMERA, live), QUALITY (JPEG, default 90),
#   DROP (share of packets to drop on purpose, to test a bad link; default 0).
#   STATS (0: quiet; N: every N frames rgbdenc posts vclassroom-codec-stats, printed by -m),
#   MTU (largest RTP packet, default 1400 for an Ethernet link; a jumbo-frame LAN takes about 9000,
#   loopback up to 65000; the server's MTU must be as large),
#   RTX (1, the default: retransmit lost packets on request; 0: plain RTP (docs/network.md); the server's
#   RTX must match),
#   RTX_KEEP_MS (how long sent packets are kept for retransmission, default 500),
#   SSRC (the camera's RTP stream id, default 0x56430000 + CAMERA: fixed, so that a camera that restarts
#   is the same stream to the server, which then takes it back at once; docs/network.md),
#   SRTP_KEY (a 30-byte key file: the frames leave encrypted with SRTP; the server needs the same file),
#   SERVER may be an IPv4 multicast group (224.0.0.0 to 239.255.255.255): every server that joins it takes
#   the camera (fan-out, docs/network.md); then SERVERS (the servers' addresses, comma-separated, whose
#   retransmission and key frame requests are taken; default 127.0.0.1), MULTICAST_IFACE (the interface to
#   send on, e.g. lo for servers on this machine; default the system's) and MULTICAST_TTL (default 1: the
#   local network only). BIND (the address to send from: the servers' CAMERA_HOSTS must name it; on lo,
#   127.0.0.1; default the system's choice).
#   RECORD (a folder: the frames sent are also recorded there, coded as sent, with their times: a live
#   recording rgbdfilesrc plays back; docs/dataset-format.md).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
# shellcheck source=pipelines/srtp.sh
. "$(dirname "$0")/srtp.sh"
CAMERA=${CAMERA:-0}
SERVER=${SERVER:-127.0.0.1}
PORT=${PORT:-$((5000 + CAMERA))}
NACK_PORT=${NACK_PORT:-$((PORT + 100))}
QUALITY=${QUALITY:-90}
DROP=${DROP:-0}
STATS=${STATS:-0}
MTU=${MTU:-1400}
RTX=${RTX:-1}
RTX_KEEP_MS=${RTX_KEEP_MS:-500}
SSRC=${SSRC:-$((0x56430000 + CAMERA))}
LINK=${LINK:-h264}
# A multicast group as SERVER: the stream goes to the group, the requests come from SERVERS.
send_opts=""
if [[ $SERVER =~ ^(22[4-9]|23[0-9])\.[0-9]{1,3}\.[0-9]{1,3}\.[0-9]{1,3}$ ]]; then
  SERVERS=${SERVERS:-127.0.0.1}
  MULTICAST_TTL=${MULTICAST_TTL:-1}
  if ! [[ $MULTICAST_TTL =~ ^[0-9]{1,3}$ ]] || ! [[ ${MULTICAST_IFACE:-lo} =~ ^[A-Za-z0-9._-]+$ ]]; then
    echo "classroom.sh: MULTICAST_TTL is 0 to 255, MULTICAST_IFACE an interface name" >&2
    exit 2
  fi
  send_opts="auto-multicast=true ttl-mc=$MULTICAST_TTL ${MULTICAST_IFACE:+multicast-iface=$MULTICAST_IFACE}"
fi
SERVERS=${SERVERS:-$SERVER}
if [ -n "${BIND:-}" ]; then
  if ! [[ $BIND =~ ^[0-9A-Fa-f.:]+$ ]]; then
    echo "classroom.sh: BIND is an IP address (got '$BIND')" >&2
    exit 2
  fi
  send_opts="$send_opts bind-address=$BIND"
fi
DEPTH_TOLERANCE=${DEPTH_TOLERANCE:-2.8}
BITRATE=${BITRATE:-4000}
KEY_INTERVAL=${KEY_INTERVAL:-60}
if [ "$LINK" != h264 ] && [ "$LINK" != vcrd1 ]; then
  echo "classroom.sh: LINK must be h264 or vcrd1 (got '$LINK')" >&2
  exit 2
fi
if ! [[ $DEPTH_TOLERANCE =~ ^[0-9]{1,3}(\.[0-9]{1,2})?$ ]] || ! [[ $BITRATE =~ ^[0-9]{3,6}$ ]] ||
   ! [[ $KEY_INTERVAL =~ ^[0-9]{1,4}$ ]] || [ "$KEY_INTERVAL" -lt 1 ]; then
  echo "classroom.sh: DEPTH_TOLERANCE is mm (e.g. 2.8), BITRATE kbit/s (100 to 999999), KEY_INTERVAL frames (1 to 9999)" >&2
  exit 2
fi
if ! [[ $SSRC =~ ^[0-9]+$ ]] || [ "$SSRC" -gt 4294967294 ]; then
  echo "classroom.sh: SSRC must be a number, 0 to 4294967294 (got '$SSRC')" >&2
  exit 2
fi
# The retransmissions' own SSRC, fixed too (server.sh expects both).
RTX_SSRC=$(( (SSRC + 0x8000) % 4294967296 ))
if ! [[ $MTU =~ ^[0-9]+$ ]] || [ "$MTU" -lt 200 ] || [ "$MTU" -gt 65000 ]; then
  echo "classroom.sh: MTU must be a packet size in bytes, 200 to 65000 (got '$MTU')" >&2
  exit 2
fi
for p in "$PORT" "$NACK_PORT"; do
  if ! [[ $p =~ ^[0-9]+$ ]] || [ "$p" -lt 1 ] || [ "$p" -gt 65535 ]; then
    echo "classroom.sh: ports must be 1 to 65535 (got '$p')" >&2
    exit 2
  fi
done
SOURCE=${SOURCE:-"rgbdtestsrc camera-id=$CAMERA is-live=true ground-truth=false"}
# STATS > 0: every STATS frames the encoder posts what it sent (printed by -m).
verbose=""
[ "$STATS" -gt 0 ] && verbose="-m"
# The RTCP session takes the server's NACKs in (only from SERVER) and asks rtprtxsend for the packets. It
# sends no reports of its own: the server does not need them, and rtpsession would hold end-of-stream on
# its RTCP output (so the script would not end when the source does).
send_session=""
to_session="udpsink host=$SERVER port=$PORT sync=false $send_opts"
if [ "$RTX" = 1 ]; then
  send_session="rtpsession name=session rtp-profile=avpf \
    udpsrc port=$NACK_PORT caps=application/x-rtcp ! senderfilter lock-ssrc=false allow=$SERVERS ! session.recv_rtcp_sink"
  to_session="rtprtxsend payload-type-map=application/x-rtp-pt-map,96=(uint)97 \
    ssrc-map=application/x-rtp-ssrc-map,$SSRC=(uint)$RTX_SSRC max-size-time=$RTX_KEEP_MS max-size-packets=0 ! \
    session.send_rtp_sink session.send_rtp_src ! identity drop-probability=$DROP ! $SRTP_ENC udpsink host=$SERVER port=$PORT sync=false $send_opts"
else
  to_session="identity drop-probability=$DROP ! $SRTP_ENC $to_session"
fi
set -f
# The coder and payloader of the link. The H.264 link: colour in I420 (constrained baseline: no B-frames, what
# every decoder plays, openh264dec included), an IDR picture at least every KEY_INTERVAL frames and on the
# server's request, SPS/PPS with every IDR (x264enc repeats them in a byte stream, so a server that joins late
# starts at the next one; rtph264pay config-interval=-1 would put them between the depth SEI and the slices,
# where rtph264depay cuts the access unit in two); the depth,
# labels and calibration ride in each access unit (rgbdlinkmux). x264enc codes in one thread: zerolatency's
# slices over several threads cost a quarter more CPU per frame (docs/network.md, "The H.264 camera link",
# "In service"), and a camera's PC is small; one thread codes a 960x540 picture in about 3 ms.
if [ "$LINK" = h264 ]; then
  coder="rgbdlinksplit ! videoconvert ! video/x-raw,format=I420 ! \
    x264enc tune=zerolatency speed-preset=ultrafast threads=1 key-int-max=$KEY_INTERVAL bitrate=$BITRATE ! \
    video/x-h264,profile=constrained-baseline ! \
    rgbdlinkmux name=enc depth-tolerance=$DEPTH_TOLERANCE key-interval=$KEY_INTERVAL stats-interval=$STATS"
  pay="rtph264pay mtu=$MTU pt=96 ssrc=$SSRC"
  recorder="rgbdenc quality=$QUALITY ! rgbdfilesink location=${RECORD:-}"
else
  coder="rgbdenc name=enc quality=$QUALITY stats-interval=$STATS"
  pay="rtpgstpay config-interval=1 mtu=$MTU pt=96 ssrc=$SSRC"
  recorder="rgbdfilesink location=${RECORD:-}"
fi
record=""
# The recording branch gets its own thread and may fall behind without holding the link back. It records
# the lossless frames (rgbdenc) whatever the link sends.
if [ -n "${RECORD:-}" ] && [ "$LINK" = h264 ]; then
  record="raw. ! queue max-size-buffers=0 max-size-bytes=0 max-size-time=0 ! $recorder"
  coder="tee name=raw ! queue ! $coder"
elif [ -n "${RECORD:-}" ]; then
  record="coded. ! queue max-size-buffers=0 max-size-bytes=0 max-size-time=0 ! $recorder"
fi
# shellcheck disable=SC2086
exec gst-launch-1.0 -e $verbose $send_session $SOURCE ! $coder ! \
  tee name=coded ! queue ! $pay ! $to_session $record
