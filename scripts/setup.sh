#!/usr/bin/env bash
# Installs what a fresh Debian 12 machine lacks (apt-get), then configures and
# builds gst-vclassroom in ./build. Safe to run again: it only does what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

# Why each package: docs/dependencies.md.
PACKAGES=(
  g++ meson ninja-build pkg-config
  libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev
  gstreamer1.0-tools gstreamer1.0-plugins-base-apps gstreamer1.0-plugins-base gstreamer1.0-plugins-good gstreamer1.0-plugins-ugly gstreamer1.0-plugins-bad
  gstreamer1.0-libav
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-calib3d-dev
  libeigen3-dev libjpeg62-turbo-dev zlib1g-dev libyaml-dev libgtest-dev
  clang libclang-rt-14-dev
  gstreamer1.0-x gstreamer1.0-gl
  ccache
  libsoup-3.0-dev libgstreamer-plugins-bad1.0-dev gstreamer1.0-nice chromium
  iproute2 coturn procps
)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
  # coturn is here for one test, which runs its own turnserver in a network namespace; the system TURN
  # service the package starts is stopped and disabled (only when this script installed it).
  if [[ " ${missing[*]} " == *" coturn "* ]] && command -v systemctl > /dev/null; then
    $SUDO systemctl disable --now coturn > /dev/null 2>&1 || true
  fi
fi

# The browser tests' driver (puppeteer-core) drives the system Chromium, and the XR test installs the WebXR
# emulation runtime iwer into the page; both pinned by the lockfile, installed again when it changed;
# skipped where npm is absent (test_webrtc then skips its browser tests, saying why).
if command -v npm > /dev/null && { [ ! -d tests/browser/node_modules ] ||
    [ tests/browser/package-lock.json -nt tests/browser/node_modules/.package-lock.json ]; }; then
  (cd tests/browser && PUPPETEER_SKIP_DOWNLOAD=1 npm ci --no-audit --no-fund)
fi

if [ ! -f build/build.ninja ]; then
  meson setup build -Dtests=enabled
fi
# One compile job per core (ninja alone runs cores + 1 on two cores, cores + 2 above).
ninja -C build -j "$(nproc)"
