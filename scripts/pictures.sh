#!/usr/bin/env bash
# Makes every picture of the guide (docs/pictures/) again with csrbf itself,
# so none goes stale: the commands under the pictures in docs/ are these.
#
#   scripts/pictures.sh            # release build, then every picture
#
# A separate command, not part of the tests: pictures drawn by the software
# renderer differ by a few levels from one Mesa to the next, and a movie of
# each demo takes minutes. Run it after a change that shows, and commit the
# pictures it writes.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh >/dev/null
cargo build --release --locked -q -p csrbf-cli
csrbf=target/release/csrbf
out=docs/pictures
mkdir -p "$out"
head=assets/models/cgal_head.off

# The smile: rest and deformed through one camera.
"$csrbf" render -q --mesh "$head" --controls assets/controls/head_smile.json \
  --before-after --view left --size 1200x520 --force --out "$out/smile-before-after.png"
# The control vectors drawn on the deformed head.
"$csrbf" render -q --mesh "$head" --controls assets/controls/head_smile.json \
  --overlay --view front --zoom 1.8 --size 800x600 --force --out "$out/smile-controls.png"
# A fold: the mouth's corner pushed 1.5 R; the faces it turns inside out in red.
"$csrbf" render -q --mesh "$head" --controls assets/controls/head_fold.json \
  --folds --view left --zoom 2.5 --target=-6,8,-0.5 --size 800x600 --force --out "$out/fold.png"
# A volume mesh: the sphere in its box moved and turned (the boundary), and
# pushed too far for its radius (the inverted cells in red).
"$csrbf" render -q --mesh assets/volume/sphere_in_box.msh --controls assets/volume/move_sphere.json \
  --before-after --size 1000x420 --force --out "$out/volume-moved.png"
"$csrbf" render -q --mesh assets/volume/sphere_in_box.msh --controls assets/volume/push_sphere.json \
  --folds --size 640x480 --force --out "$out/volume-folds.png"
# The papers' demos: each one's poster (the movies go to target/).
demos=target/pictures/demos
mkdir -p target/pictures
"$csrbf" demo all -q --out "$demos" --size 640x480
for d in face fish ball brick; do
  cp "$demos/$d/poster.png" "$out/demo-$d.png"
done
# The studio's Picker and Composer as the app draws them (on the software
# renderer here), and the demos' posters as one picture for the README.
cargo run --release --locked -q -p csrbf-studio --example guide_pictures -- "$demos" "$out"
echo "pictures: wrote $(ls "$out" | wc -l) pictures into $out/"
