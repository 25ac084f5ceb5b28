# Sourced first by every pipeline script: finds the source tree (this folder's parent) and makes sure
# GStreamer finds the project's plugins. A build folder (VCLASSROOM_BUILD_DIR, set by meson devenv, else the
# source tree's build/) gives its plugins, tools and lecturer page as meson devenv would, whatever is
# installed, so a fresh build is what runs, from the source root, from the build folder or from anywhere
# else; without one (the scripts installed) the installed plugins are used. Without either, the script
# stops and says what to do.
VCLASSROOM_SOURCE_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

vclassroom_build=${VCLASSROOM_BUILD_DIR:-$VCLASSROOM_SOURCE_DIR/build}
vclassroom_plugins=$(ls -d "$vclassroom_build"/plugins/*/ 2>/dev/null | tr '\n' ':' || true)
if [ -n "$vclassroom_plugins" ]; then
  export GST_PLUGIN_PATH="${vclassroom_plugins%:}${GST_PLUGIN_PATH:+:$GST_PLUGIN_PATH}"
  export GST_REGISTRY="$vclassroom_build/registry.bin"
  export PATH="$vclassroom_build/tools:$PATH"
  export VCLASSROOM_WEB_ROOT="${VCLASSROOM_WEB_ROOT:-$VCLASSROOM_SOURCE_DIR/web/lecturer}"
  export VCLASSROOM_BUILD_DIR="$vclassroom_build"
fi
# (--exists alone asks for GStreamer's own version, 1.22; the project's plugins are 0.x.)
if ! gst-inspect-1.0 --exists --atleast-version=0.0.0 viewfuse 2>/dev/null; then
  if [ -n "$vclassroom_plugins" ]; then
    echo "$(basename "$0"): the build folder $vclassroom_build has no element viewfuse: build it (ninja -C $vclassroom_build)" >&2
  else
    echo "$(basename "$0"): GStreamer has no element viewfuse and there is no build folder at $vclassroom_build:" \
         "build the project first (scripts/setup.sh), set VCLASSROOM_BUILD_DIR to its build folder, or meson install" >&2
  fi
  exit 1
fi
