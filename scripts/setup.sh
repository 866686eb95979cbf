#!/usr/bin/env bash
# Installs what csrbf needs beyond a Rust toolchain, only where it is missing:
# Mesa's software Vulkan driver (pictures without a GPU), ffmpeg (MP4 movies),
# the X11 libraries the studio's window opens with, and, with --tests, the
# Khronos glTF validator (npm) for the export tests and Xvfb, xdotool and
# ImageMagick for the studio's real-window test (also what scripts/studio.sh
# uses on a machine without a display).
set -euo pipefail
cd "$(dirname "$0")/.."

need=()
[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ] || [ -e /usr/share/vulkan/icd.d/lvp_icd.aarch64.json ] || need+=(mesa-vulkan-drivers)
ldconfig -p 2>/dev/null | grep -q libvulkan.so.1 || need+=(libvulkan1)
command -v ffmpeg >/dev/null 2>&1 || need+=(ffmpeg)
for lib in libxkbcommon-x11.so.0:libxkbcommon-x11-0 libX11-xcb.so.1:libx11-xcb1 libXcursor.so.1:libxcursor1 libXrandr.so.2:libxrandr2 libXi.so.6:libxi6; do
  ldconfig -p 2>/dev/null | grep -q "${lib%%:*}" || need+=("${lib##*:}")
done
if [ "${1:-}" = "--tests" ] || [ "${1:-}" = "--studio" ]; then
  command -v Xvfb >/dev/null 2>&1 || need+=(xvfb xauth)
  command -v xdotool >/dev/null 2>&1 || need+=(xdotool)
  command -v import >/dev/null 2>&1 || need+=(imagemagick)
fi
if [ "${1:-}" = "--tests" ] && ! command -v node >/dev/null 2>&1; then need+=(nodejs npm); fi
# The Python package's tests (scripts/test_python.sh) make venvs.
if [ "${1:-}" = "--tests" ]; then
  command -v python3 >/dev/null 2>&1 || need+=(python3)
  python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || need+=(python3-venv)
fi
if [ ${#need[@]} -gt 0 ]; then
  if command -v apt-get >/dev/null 2>&1; then
    sudo=""; [ "$(id -u)" = 0 ] || sudo="sudo"
    echo "setup: installing ${need[*]}"
    export DEBIAN_FRONTEND=noninteractive
    $sudo apt-get update -qq
    $sudo apt-get install -y -qq "${need[@]}" >/dev/null
  else
    echo "setup: please install: ${need[*]} (Mesa's Vulkan driver, the Vulkan loader, ffmpeg)" >&2
  fi
fi

if [ "${1:-}" = "--tests" ] && [ ! -d .tools/node_modules/gltf-validator ]; then
  echo "setup: installing the Khronos glTF validator into .tools/"
  mkdir -p .tools
  [ -f .tools/package.json ] || echo '{"private": true}' > .tools/package.json
  (cd .tools && npm install --no-save --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10)
fi

# Mesa complains without a runtime folder; give it one.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
  mkdir -p -m 700 /tmp/xdg-"$(id -u)"
fi
