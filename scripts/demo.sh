#!/usr/bin/env bash
# Set-up + the main job: the full classroom -> server -> lecturer flow on the synthetic
# classroom, all in one pipeline: three cameras (sensor model on) -> V-DA (depthcomplete,
# planerefine) -> V-VA (learnerseg, viewwarp, viewfuse) along a lecturer's walk and head turn
# -> out/all-in-one.mp4. Also writes the three cameras' own view (out/classroom-preview.mp4).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
mkdir -p out
# `meson devenv` puts the uninstalled plugins and tools on the paths.
run() { meson devenv -C build -w "$PWD" "$@"; }
if [ ! -f out/model/rig.yaml ]; then
  echo "Building the static classroom model (the empty room, V-DA step 1) ..."
  run vclassroom-build-model --synthetic --out out/model
fi
run env OUT="$PWD/out/classroom-preview.mp4" FRAMES=90 pipelines/classroom-preview.sh > /dev/null
run env OUT="$PWD/out/all-in-one.mp4" MODEL="$PWD/out/model" pipelines/all-in-one.sh
echo
echo "Main job done:"
echo "  $PWD/out/all-in-one.mp4        the lecturer's view, synthesized from the three cameras (10 s)"
echo "  $PWD/out/classroom-preview.mp4 what the three cameras see: colour above, depth below"
echo "Watch them with any video player, e.g.: gst-play-1.0 out/all-in-one.mp4"
