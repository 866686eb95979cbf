#!/usr/bin/env bash
# The main job: deform the bundled head by the bundled smile controls and
# write the result (and its half-way phase) under out/.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p out
cargo build --release -q -p csrbf-cli
bin=target/release/csrbf
$bin info --controls assets/controls/head_smile.json
$bin deform --mesh assets/models/cgal_head.off --controls assets/controls/head_smile.json --out out/head_smile.obj
$bin deform --mesh assets/models/cgal_head.off --controls assets/controls/head_smile.json --phase 0.5 --out out/head_half.obj
$bin fit --controls assets/controls/head_smile.json --out out/head_smile.csrbf
echo
echo "Wrote out/head_smile.obj (full smile), out/head_half.obj (phase 0.5) and out/head_smile.csrbf (replay file)."
echo "Open the OBJ files in any mesh viewer (Blender, MeshLab, f3d) next to assets/models/cgal_head.off."
