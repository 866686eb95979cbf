#!/usr/bin/env bash
# Builds and starts the studio on a mesh (the Picker), the bundled head by
# default, or on a scene file (the Composer): scripts/studio.sh [MESH
# [CONTROLS] | SCENE.scene.json]. On a machine without a
# display it starts the studio under Xvfb, keeps a screenshot in
# target/studio.png after a few seconds and says so.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --studio
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
mkdir -p -m 700 "$XDG_RUNTIME_DIR"
cargo build --release --locked -p csrbf-studio
mesh="${1:-assets/models/cgal_head.off}"
shift || true
if [ -n "${DISPLAY:-}" ] || [ -n "${WAYLAND_DISPLAY:-}" ]; then
  exec target/release/csrbf-studio "$mesh" "$@"
fi
echo "studio: no display here; starting it under Xvfb for a screenshot"
xvfb-run -a -s "-screen 0 1280x860x24" sh -c '
  target/release/csrbf-studio "$0" --size 1280x800 "$@" & app=$!
  sleep 8; import -window root target/studio.png; kill $app' "$mesh" "$@"
echo "studio: screenshot written to target/studio.png (run on a machine with a display to use it)"
