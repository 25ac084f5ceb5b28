#!/usr/bin/env bash
# Server: N RTP camera inputs -> decode -> V-DA -> V-VA -> JPEG -> RTP -> UDP to the lecturer;
# pose packets from the lecturer come back on POSE_PORT and steer the view.
# Variables: CAMERAS (ids, default "0 1 2"), BASE_PORT (camera k on BASE_PORT + k, default 5000),
#   CAMERA_PORTS (one port per camera in CAMERAS order, instead of BASE_PORT + k),
#   LECTURER (host, default 127.0.0.1), VIDEO_PORT (default 5010), POSE_PORT (default 5011),
#   MODEL (folder from vclassroom-build-model; empty: no V-DA), RIG (rig file; empty: the default classroom rig),
#   WIDTH/HEIGHT (virtual view, default 960x540), QUALITY (JPEG quality of the lecturer's video, default 90).
#   STATS (0: quiet; N: every N frames each camera's decoder posts vclassroom-codec-stats, printed by -m),
#   MTU (largest RTP packet received from the cameras and sent to the lecturer, default 1400; as classroom.sh),
#   PREP_NICE (nice value of the threads that decode, complete and segment camera frames, default 10: when
#   the CPU is short, warping, fusing and sending the lecturer's view go first; 0 shares it evenly),
#   FUSE_LATENCY (ns the fuse waits for a late camera's frame before rendering without it, default 100000000).
#   POSE_KEY (file holding the pose key shared with lecturer.sh, e.g. `head -c 32 /dev/urandom > pose.key`:
#   only poses tagged with it steer the view; empty: anyone who can reach POSE_PORT can steer it).
set -euo pipefail
CAMERAS=${CAMERAS:-"0 1 2"}
BASE_PORT=${BASE_PORT:-5000}
LECTURER=${LECTURER:-127.0.0.1}
VIDEO_PORT=${VIDEO_PORT:-5010}
POSE_PORT=${POSE_PORT:-5011}
MODEL=${MODEL:-}
RIG=${RIG:-}
WIDTH=${WIDTH:-960}
HEIGHT=${HEIGHT:-540}
QUALITY=${QUALITY:-90}
# A 960x540 RGB-D frame is ~400 packets sent at once: the socket must hold a few frames.
UDP_BUFFER=${UDP_BUFFER:-33554432}
STATS=${STATS:-0}
MTU=${MTU:-1400}
if ! [[ $MTU =~ ^[0-9]+$ ]] || [ "$MTU" -lt 200 ] || [ "$MTU" -gt 65000 ]; then
  echo "server.sh: MTU must be a packet size in bytes, 200 to 65000 (got '$MTU')" >&2
  exit 2
fi
PREP_NICE=${PREP_NICE:-10}
if ! [[ $PREP_NICE =~ ^[0-9]+$ ]] || [ "$PREP_NICE" -gt 19 ]; then
  echo "server.sh: PREP_NICE must be a nice value, 0 to 19 (got '$PREP_NICE')" >&2
  exit 2
fi
pose_key=""
[ -n "${POSE_KEY:-}" ] && pose_key="key-file=$POSE_KEY"
POSE_EXT="extmap-3=(string)urn:gst-vclassroom:rtp-hdrext:pose"

read -r -a camera_ports <<< "${CAMERA_PORTS:-}"
branches=""
i=0
for k in $CAMERAS; do
  port=${camera_ports[$i]:-$((BASE_PORT + k))}
  i=$((i + 1))
  vda=""
  [ -n "$MODEL" ] && vda="depthcomplete model=$MODEL ! planerefine model=$MODEL !"
  prior=""
  [ -n "$MODEL" ] && prior="prior-depth=$MODEL/prior-depth/cam$k.png"
  rig=""
  [ -n "$RIG" ] && rig="rig=$RIG"
  branches="$branches udpsrc port=$port buffer-size=$UDP_BUFFER mtu=$((MTU + 100)) caps=\"application/x-rtp,media=application,clock-rate=90000,encoding-name=X-GST\" ! \
    rtpjitterbuffer latency=50 drop-on-latency=true ! rtpgstdepay ! \
    queue max-size-buffers=1 leaky=downstream ! threadpriority nice=$PREP_NICE ! rgbddec name=dec$k stats-interval=$STATS ! \
    $vda learnerseg $prior ! queue max-size-buffers=1 leaky=downstream ! viewwarp $rig width=$WIDTH height=$HEIGHT $prior ! fuse.cam_$k"
done
# Word-split the description (no globbing): gst-launch-1.0 takes one word per
# argument and handles the quotes inside them itself.
set -f
FUSE_LATENCY=${FUSE_LATENCY:-100000000}
desc="viewfuse name=fuse latency=$FUSE_LATENCY ! poserecv name=poses $pose_key ! \
  jpegenc quality=$QUALITY ! rtpgstpay config-interval=1 mtu=$MTU ! application/x-rtp,$POSE_EXT ! \
  udpsink host=$LECTURER port=$VIDEO_PORT sync=false \
  udpsrc port=$POSE_PORT caps=\"application/x-rtp,media=application,clock-rate=90000,encoding-name=X-VCLASSROOM-POSE,payload=96\" ! poses.rtp \
  $branches"
# shellcheck disable=SC2086
# STATS > 0: every STATS frames each decoder posts what it got (printed by -m).
verbose=""
[ "$STATS" -gt 0 ] && verbose="-m"
exec gst-launch-1.0 -e $verbose $desc
