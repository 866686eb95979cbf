#!/usr/bin/env bash
# Builds the Blender extension's installable zip, dist/csrbf_blender-VERSION.zip:
# the add-on (blender/csrbf_blender) with the csrbf wheel for this platform
# under wheels/. Install it in Blender with Edit > Preferences > Get Extensions
# > Install from Disk (Blender 4.2 or newer).
#
#   scripts/build-blender-extension.sh              # builds the wheel (release)
#   scripts/build-blender-extension.sh --wheel W    # packs a wheel built before
#   ... --out DIR                                   # the zip into DIR (not dist/)
#
# The wheel is abi3 (CPython 3.9 and newer): the same file serves Blender
# 4.2-5.0 (CPython 3.11) and 5.1+ (CPython 3.13). It is built for the machine
# it is built on: build on (or for) each platform your users run Blender on
# (Linux x86_64, Windows x86_64, macOS arm64/x86_64), one zip each.
set -euo pipefail
cd "$(dirname "$0")/.."
wheel=""
out_dir=dist
while [ $# -gt 0 ]; do
  case "$1" in
    --wheel) wheel=$2; shift 2 ;;
    --out) out_dir=$2; shift 2 ;;
    *) echo "build-blender-extension: unknown argument $1 (--wheel W, --out DIR)" >&2; exit 2 ;;
  esac
done
if [ -z "$wheel" ]; then
  build=.venv-build
  [ -x "$build/bin/python" ] || python3 -m venv "$build"
  "$build/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.9,<2"
  rm -rf target/blender-wheel
  "$build/bin/maturin" build -q --release --locked -m crates/csrbf-py/Cargo.toml -o target/blender-wheel
  wheel=$(ls target/blender-wheel/csrbf-*.whl)
fi
[ -f "$wheel" ] || { echo "build-blender-extension: no wheel at $wheel" >&2; exit 1; }
name=$(basename "$wheel")
version=$(sed -n 's/^version = "\(.*\)"/\1/p' blender/csrbf_blender/blender_manifest.toml)
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/wheels"
cp blender/csrbf_blender/*.py "$stage/"
sed "s|./wheels/WHEEL_PLACEHOLDER|./wheels/$name|" blender/csrbf_blender/blender_manifest.toml \
  > "$stage/blender_manifest.toml"
cp "$wheel" "$stage/wheels/"
mkdir -p "$out_dir"
out="$out_dir/csrbf_blender-$version.zip"
# Whole or not at all: packed beside the target, then renamed.
python3 scripts/zip_folder.py "$stage" "$out"
echo "build-blender-extension: wrote $out ($(du -h "$out" | cut -f1), wheel $name)"
