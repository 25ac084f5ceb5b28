#!/usr/bin/env bash
# Set-up + the main job: the classroom flow on the synthetic classroom, written
# to a video file you can watch. (It grows with the project: today it shows the
# three classroom cameras, colour and depth.)
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export OUT=${OUT:-$PWD/out/classroom-preview.mp4}
# `meson devenv` puts the uninstalled plugins and tools on the paths.
meson devenv -C build -w "$PWD" pipelines/classroom-preview.sh
echo
echo "Main job done: $OUT"
echo "Watch it with any video player, e.g.: gst-play-1.0 $OUT"
