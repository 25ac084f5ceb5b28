#!/usr/bin/env bash
# Lecturer side: RTP video from the server -> decode -> posenav -> a window; the poses posenav makes
# (mouse, keys, SLIDERS or a POSE_TRACE) go back to the server through posesend.
# Variables: SERVER (host, default 127.0.0.1), VIDEO_PORT (default 5010), POSE_PORT (default 5011),
#   RIG (rig file the sliders refer to; empty: the rig origin), SLIDERS (start view, default [50,50,50,50,50,50]),
#   POSE_TRACE (CSV; empty: interactive), SINK (default autovideosink; e.g. "fakesink" or a file branch),
#   MTU (largest RTP packet from the server, default 1400; as server.sh),
#   POSE_KEY (file holding the pose key shared with server.sh: every pose is tagged with it; empty: untagged),
#   VIDEO_SENDERS (addresses the video is taken from, default SERVER): packets from elsewhere, or a second
#   video stream, are dropped and counted (senderfilter, docs/network.md).
#   SRTP_KEY (a 30-byte key file: video and sound in and poses out are SRTP; the server needs the same file),
#   POSES_OUT (a file: every pose sent is also written there as a pose trace, docs/pose.md),
#   SPEAKER (where the classroom's sound plays, e.g. autoaudiosink; empty, the default: not played),
#   AUDIO_PORT (the sound from the server's CLASSROOM_SOUND, default 5012).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
# shellcheck source=pipelines/srtp.sh
. "$(dirname "$0")/srtp.sh"
SERVER=${SERVER:-127.0.0.1}
VIDEO_PORT=${VIDEO_PORT:-5010}
POSE_PORT=${POSE_PORT:-5011}
SLIDERS=${SLIDERS:-"[50,50,50,50,50,50]"}
SINK=${SINK:-autovideosink}
MTU=${MTU:-1400}
VIDEO_SENDERS=${VIDEO_SENDERS:-$SERVER}
AUDIO_PORT=${AUDIO_PORT:-5012}
for p in "$VIDEO_PORT" "$POSE_PORT" "$AUDIO_PORT"; do
  if ! [[ $p =~ ^[0-9]+$ ]] || [ "$p" -lt 1 ] || [ "$p" -gt 65535 ]; then
    echo "lecturer.sh: ports must be 1 to 65535 (got '$p')" >&2
    exit 2
  fi
done
if ! [[ $MTU =~ ^[0-9]+$ ]] || [ "$MTU" -lt 200 ] || [ "$MTU" -gt 65000 ]; then
  echo "lecturer.sh: MTU must be a packet size in bytes, 200 to 65000 (got '$MTU')" >&2
  exit 2
fi
nav="sliders=\"$SLIDERS\""
[ -n "${RIG:-}" ] && nav="$nav rig=$RIG"
[ -n "${POSE_TRACE:-}" ] && nav="$nav pose-trace=$POSE_TRACE"
posesend_props=""
[ -n "${POSE_KEY:-}" ] && posesend_props="key-file=$POSE_KEY"
[ -n "${POSES_OUT:-}" ] && posesend_props="$posesend_props trace-location=$POSES_OUT"
# Word-split the description (no globbing): gst-launch-1.0 takes one word per
# argument and handles the quotes inside them itself.
set -f
desc="udpsrc port=$VIDEO_PORT buffer-size=8388608 mtu=$((MTU + 100)) caps=\"$RTP_MEDIA,media=application,clock-rate=90000,encoding-name=X-GST,extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose\" ! \
  senderfilter name=from_server allow=$VIDEO_SENDERS payload-types=96 ! $(srtp_dec) rtpjitterbuffer latency=30 ! rtpgstdepay ! jpegdec ! posesend name=back $posesend_props ! videoconvert ! posenav $nav ! $SINK \
  back.rtp ! $SRTP_ENC udpsink host=$SERVER port=$POSE_PORT sync=false async=false"
# The classroom's sound, where SPEAKER names a place to play it: lost packets concealed (Opus in-band FEC).
[ -n "${SPEAKER:-}" ] &&
  desc="$desc udpsrc port=$AUDIO_PORT caps=\"$RTP_MEDIA,media=audio,clock-rate=48000,encoding-name=OPUS,payload=97\" ! \
    senderfilter name=sound_from_server allow=$VIDEO_SENDERS payload-types=97 ! $(srtp_dec) rtpjitterbuffer latency=30 ! \
    rtpopusdepay ! opusdec plc=true use-inband-fec=true ! audioconvert ! audioresample ! $SPEAKER"
# shellcheck disable=SC2086
exec gst-launch-1.0 -e $desc
