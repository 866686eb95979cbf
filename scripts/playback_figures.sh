#!/usr/bin/env bash
# Issue 9's playback figures, measured in the real app: each demo scene (and
# the 126k-vertex Suzanne scene when ../shared/models has it) is opened in
# the release csrbf-studio at 1280x800 under Xvfb, played once through with
# Space, and the app's own log line ("played N frames in T s = F fps, D
# dropped") is printed. Needs Xvfb and xdotool (scripts/setup.sh --tests).
set -euo pipefail
cd "$(dirname "$0")/.."
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
mkdir -p -m 700 "$XDG_RUNTIME_DIR"
out="${OUT:-target/playback}"
mkdir -p "$out"
cargo build --release --locked -p csrbf-studio --bin csrbf-studio --example play_frame
echo "headless (engine + picture, no window):"
OUT="$out" target/release/examples/play_frame
echo
echo "in the app (1280x800 window under Xvfb, lavapipe):"
for scene in "$out"/*.scene.json; do
  log="$out/$(basename "$scene" .scene.json).log"
  CSRBF_STUDIO_STATE="$out/state" xvfb-run -a -s "-screen 0 1280x860x24" sh -c '
    start=$(date +%s%N)
    target/release/csrbf-studio "$0" --size 1280x800 2>"$1" & app=$!
    until xdotool search --name "csrbf studio" >/dev/null 2>&1; do sleep 0.2; done
    opened=$(( ($(date +%s%N) - start) / 1000000 ))
    sleep 3
    xdotool search --name "csrbf studio" windowfocus --sync
    xdotool key space
    sleep 4
    xdotool key space
    sleep 1
    kill $app; wait $app 2>/dev/null || true
    echo "window after ${opened} ms" >>"$1"' "$scene" "$log"
  echo "$(basename "$scene"): $(grep -h "played\|window after\|Opened" "$log" | tr '\n' ' ')"
done

echo
echo "export: csrbf animate against the studio's File > Export movie (Ctrl+E), same scene, MP4:"
cargo build --release --locked -p csrbf-cli
for scene in "$out"/*.scene.json; do
  name=$(basename "$scene" .scene.json)
  rm -f "$out/$name.cli.mp4" "$out/$name.app.mp4"
  start=$(date +%s%N)
  target/release/csrbf animate "$scene" --out "$out/$name.cli.mp4" -q >/dev/null 2>&1 || true
  cli=$(( ($(date +%s%N) - start) / 1000000 ))
  log="$out/$name.export.log"
  CSRBF_STUDIO_STATE="$out/state" xvfb-run -a -s "-screen 0 1280x860x24" sh -c '
    target/release/csrbf-studio "$0" --size 1280x800 2>"$1" & app=$!
    until xdotool search --name "csrbf studio" >/dev/null 2>&1; do sleep 0.2; done
    sleep 3
    xdotool search --name "csrbf studio" windowfocus --sync
    xdotool key ctrl+e; sleep 0.5
    xdotool key ctrl+a; xdotool type --delay 5 "$2"; xdotool key Return
    until grep -q "csrbf-studio: Wrote\|Cannot" "$1"; do sleep 0.2; done
    kill $app; wait $app 2>/dev/null || true' "$scene" "$log" "$(realpath "$out")/$name.app.mp4"
  echo "$name: csrbf animate ${cli} ms; studio: $(grep -h "Wrote" "$log" | sed 's/.* in //')"
done
