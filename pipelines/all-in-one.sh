#!/usr/bin/env bash
# The first live demo (docs/vva.md): three synthetic classroom cameras -> [V-DA when a
# model is given] -> learnerseg -> viewwarp (one per camera) -> viewfuse -> H.264 in an MP4
# file. Every viewwarp plays the lecturer's pose trace (a slow walk and head turn through the
# front of the class) by its frames' time, so the cameras' frames of one instant are warped
# for the same pose however far apart the branches run.
# Variables: OUT (file, default out/all-in-one.mp4), FRAMES (default 300 = 10 s),
# TRACE (pose trace CSV, default pipelines/lecturer-walk.csv), SEED (default 1),
# LEARNERS (default 6), MODEL (a folder from vclassroom-build-model: when set, V-DA
# (depthcomplete, planerefine) cleans each camera's depth and its prior depth is the static layer),
# MEMORY (frames of viewwarp's background memory, default 8, 0: off; with MODEL it starts from the
# model's empty-room colour and draws the room behind the learners, as server.sh),
# BUILD (build folder for the tools when they are not on PATH, default the one trees.sh found, else the source
# tree's build/).
set -euo pipefail
. "$(dirname "$0")/trees.sh"
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${OUT:-out/all-in-one.mp4}
FRAMES=${FRAMES:-300}
TRACE=${TRACE:-$HERE/lecturer-walk.csv}
SEED=${SEED:-1}
LEARNERS=${LEARNERS:-6}
MEMORY=${MEMORY:-8}
BUILD=${BUILD:-${VCLASSROOM_BUILD_DIR:-$VCLASSROOM_SOURCE_DIR/build}}
if ! [[ $MEMORY =~ ^[0-9]+$ ]] || [ "$MEMORY" -gt 64 ]; then
  echo "all-in-one.sh: MEMORY must be a number of frames, 0 (off) to 64 (got '$MEMORY')" >&2
  exit 2
fi
mkdir -p "$(dirname "$OUT")"

# The static layer's depth per camera: V-DA's prior depth when a model is given, else
# the empty classroom's exact depth (a stand-in, written by vclassroom-eval-views).
VDA=""
if [ -n "${MODEL:-}" ]; then
  VDA="! depthcomplete model=$MODEL ! planerefine model=$MODEL"
  prior() { echo "$MODEL/prior-depth/cam$1.png"; }
else
  EVAL=$(command -v vclassroom-eval-views || echo "$BUILD/tools/vclassroom-eval-views")
  PRIORS=$(mktemp -d)
  trap 'rm -rf "$PRIORS"' EXIT
  "$EVAL" --write-priors "$PRIORS" > /dev/null
  prior() { echo "$PRIORS/prior-cam$1.png"; }
fi

branches=""
for k in 0 1 2; do
  memory=""
  [ "$MEMORY" != 0 ] && memory="background-memory=$MEMORY${MODEL:+ empty-room=$MODEL/prior-color/cam$k.png}"
  branches="$branches rgbdtestsrc camera-id=$k seed=$SEED learners=$LEARNERS num-buffers=$FRAMES ground-truth=false $VDA \
    ! learnerseg prior-depth=$(prior $k) \
    ! viewwarp prior-depth=$(prior $k) pose-trace=\"$TRACE\" $memory ! queue max-size-buffers=2 ! fuse.cam_$k"
done
echo "all-in-one: 3 cameras ${MODEL:+-> depthcomplete -> planerefine }-> learnerseg -> viewwarp -> viewfuse (pose trace $TRACE) -> $OUT"
# I420: from viewfuse's RGB, x264enc would otherwise pick High 4:4:4, which browsers and most players cannot play.
eval gst-launch-1.0 -e \
  viewfuse name=fuse ! videoconvert ! video/x-raw,format=I420 ! x264enc speed-preset=veryfast tune=zerolatency \
  ! mp4mux ! filesink location="$OUT" $branches
echo "wrote $OUT"
