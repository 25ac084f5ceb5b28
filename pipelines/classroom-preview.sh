#!/usr/bin/env bash
# The synthetic classroom as its three cameras see it: colour on top, depth
# (turbo colours, black = no measurement) below, encoded to an MP4 file.
# Variables: OUT (file, default out/classroom-preview.mp4), FRAMES (default 150 = 5 s),
# RIG (rig file, default: the built-in 3-camera rig), SEED (default 1), LEARNERS (default 3).
# Runs from the source root, the build folder or installed (pipelines/trees.sh finds the plugins).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
OUT=${OUT:-out/classroom-preview.mp4}
FRAMES=${FRAMES:-150}
SEED=${SEED:-1}
LEARNERS=${LEARNERS:-3}
RIG_PROP=""
[ -n "${RIG:-}" ] && RIG_PROP="rig=$RIG"
mkdir -p "$(dirname "$OUT")"

W=640 H=360
cam() {  # camera k → tile k of the top (colour) and bottom (depth) rows
  local k=$1
  echo "rgbdtestsrc camera-id=$k seed=$SEED learners=$LEARNERS num-buffers=$FRAMES $RIG_PROP ! rgbddemux name=d$k \
    d$k.color ! queue ! videoscale ! video/x-raw,width=$W,height=$H ! mix.sink_$((2*k)) \
    d$k.depth ! queue ! depthcolorize min-depth=800 max-depth=7000 ! videoscale ! video/x-raw,width=$W,height=$H ! mix.sink_$((2*k+1))"
}
# Tiles left to right as the cameras stand: camera 1 (left), 0 (centre), 2 (right).
column() { case $1 in 1) echo 0 ;; 0) echo 1 ;; *) echo 2 ;; esac; }
pads=""
for k in 0 1 2; do
  x=$(( $(column $k) * W ))
  pads="$pads sink_$((2*k))::xpos=$x sink_$((2*k))::ypos=0 sink_$((2*k+1))::xpos=$x sink_$((2*k+1))::ypos=$H"
done
eval gst-launch-1.0 -e \
  compositor name=mix $pads ! video/x-raw,width=$((3*W)),height=$((2*H)) ! videoconvert ! \
    x264enc speed-preset=faster tune=stillimage bitrate=6000 ! video/x-h264,profile=high ! mp4mux ! filesink location="$OUT" \
  "$(cam 0)" "$(cam 1)" "$(cam 2)"
echo "wrote $OUT"
