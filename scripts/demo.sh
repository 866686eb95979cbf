#!/usr/bin/env bash
# The main job: renders the papers' face example (the bundled head smiles and
# relaxes) as a movie with a poster and its scene file, and deforms the head
# into mesh files, all under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
mkdir -p out
cargo build --release -q -p csrbf-cli
bin=target/release/csrbf
echo "== The control file: what it asks for and the system it makes (csrbf info) =="
$bin info --controls assets/controls/head_smile.json
echo
echo "== The head deformed by it, and the deformation saved for replay (csrbf deform, csrbf fit) =="
$bin deform --mesh assets/models/cgal_head.off --controls assets/controls/head_smile.json --out out/head_smile.obj --force
$bin fit --controls assets/controls/head_smile.json --out out/head_smile.csrbf --force
echo
echo "== The papers' face example: scene, models, poster and movie (csrbf demo face) =="
$bin demo face --out out/demos
echo
echo "The movie:  out/demos/face/movie.mp4 (poster: out/demos/face/poster.png, scene: out/demos/face/face.scene.json)"
echo "The mesh:   out/head_smile.obj (deformed), out/head_smile.csrbf (replay file)"
echo "More:       $bin demo all --out out/demos   (face, fish, ball, brick)"
