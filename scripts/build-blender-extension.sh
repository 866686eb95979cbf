#!/usr/bin/env bash
# Builds the Blender extension's installable zips: the add-on
# (blender/csrbf_blender) with the csrbf wheel of one platform each, as
# Blender's own extension tool builds them (`blender_ext.py build
# --split-platforms`, from the bpy module): dist/csrbf-blender-VERSION-linux_x64.zip,
# ...-windows_x64.zip, ...-macos_arm64.zip, one per wheel given. Each zip's
# manifest names its platform and its wheel, and each is validated by the
# same tool before it is kept. Install one in Blender with Edit > Preferences
# > Get Extensions > Install from Disk (Blender 4.2 or newer).
#
#   scripts/build-blender-extension.sh                   # builds this machine's wheel (release)
#   scripts/build-blender-extension.sh --wheel W [--wheel W2 ...]  # packs wheels built before
#   ... --out DIR                                        # the zips into DIR (not dist/)
#
# The wheels are abi3 (CPython 3.9 and newer): one file serves Blender 4.2-5.0
# (CPython 3.11) and 5.1+ (CPython 3.13). scripts/release.sh gives the Linux,
# Windows (and where built, macOS) wheels. Blender's tool comes from the bpy
# venv of scripts/blender_venv.sh (CPython 3.11; downloaded once per machine).
set -euo pipefail
cd "$(dirname "$0")/.."
wheels=()
out_dir=dist
while [ $# -gt 0 ]; do
  case "$1" in
    --wheel) wheels+=("$2"); shift 2 ;;
    --out) out_dir=$2; shift 2 ;;
    *) echo "build-blender-extension: unknown argument $1 (--wheel W, --out DIR)" >&2; exit 2 ;;
  esac
done
if [ ${#wheels[@]} -eq 0 ]; then
  build=.venv-build
  [ -x "$build/bin/python" ] || python3 -m venv "$build"
  "$build/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.9,<2"
  rm -rf target/blender-wheel
  "$build/bin/maturin" build -q --release --locked -m crates/csrbf-py/Cargo.toml -o target/blender-wheel
  wheels=("$(ls target/blender-wheel/csrbf-*.whl)")
fi
for w in "${wheels[@]}"; do
  [ -f "$w" ] || { echo "build-blender-extension: no wheel at $w" >&2; exit 1; }
done
source scripts/blender_venv.sh

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
src="$stage/csrbf"
mkdir -p "$src/wheels" "$stage/out"
cp blender/csrbf_blender/*.py "$src/"
cp "${wheels[@]}" "$src/wheels/"
# The manifest names every wheel and the platforms they are for; Blender's
# tool writes each platform's zip with its own wheels and platform.
"$blender_python" - blender/csrbf_blender/blender_manifest.toml "$src/blender_manifest.toml" "$blender_ext_cli" "${wheels[@]}" <<'PY'
import importlib.util, os, sys
source, target, ext_cli, *wheels = sys.argv[1:]
spec = importlib.util.spec_from_file_location("blender_ext", ext_cli)
ext = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ext)
platforms = []
for w in wheels:
    name = os.path.basename(w)
    tag = name[:-len(".whl")].split("-")[-1]
    found = [p for t in tag.split(".") for p in ext.blender_platforms_from_wheel_platform(t)]
    found = sorted(set(found))
    if len(found) != 1 or found[0] not in ("linux-x64", "windows-x64", "macos-arm64", "macos-x64"):
        sys.exit(f"build-blender-extension: {name} is not for one of Blender's platforms: {found}")
    if found[0] in platforms:
        sys.exit(f"build-blender-extension: two wheels for {found[0]}")
    platforms.append(found[0])
text = open(source).read()
listed = ",\n".join(f'  "./wheels/{os.path.basename(w)}"' for w in wheels)
placeholder = '  "./wheels/WHEEL_PLACEHOLDER",\n]\n'
assert placeholder in text, "the manifest's wheels placeholder moved"
# `platforms` beside `wheels`, before the manifest's first table.
text = text.replace(placeholder, listed + ",\n]\n\nplatforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]\n")
open(target, "w").write(text)
print("build-blender-extension: platforms " + " ".join(platforms))
PY
# (The tool writes its errors to stdout: shown when it fails.)
if ! "$blender_python" "$blender_ext_cli" build --source-dir "$src" --output-dir "$stage/out" --split-platforms > "$stage/build.log" 2>&1; then
  echo "build-blender-extension: Blender's tool could not build the zips:" >&2
  cat "$stage/build.log" >&2
  exit 1
fi
mkdir -p "$out_dir"
zips=("$stage"/out/*.zip)
[ -e "${zips[0]}" ] || { echo "build-blender-extension: Blender's tool wrote no zip" >&2; exit 1; }
for z in "${zips[@]}"; do
  "$blender_python" "$blender_ext_cli" validate "$z" >/dev/null || {
    echo "build-blender-extension: Blender refuses $(basename "$z"):" >&2
    "$blender_python" "$blender_ext_cli" validate "$z" >&2 || true
    exit 1
  }
done
source scripts/sums.sh
# Whole or not at all: every zip was written and validated in the stage;
# each is moved beside its final name, then renamed over it.
for z in "${zips[@]}"; do
  # Blender names them ID-VERSION-PLATFORM.zip; "csrbf-blender-" tells them
  # from the programs' archives.
  name=$(basename "$z"); name="csrbf-blender-${name#csrbf-}"
  mv "$z" "$out_dir/$name.tmp"
  mv "$out_dir/$name.tmp" "$out_dir/$name"
  update_sums "$out_dir" "$name"
  echo "build-blender-extension: wrote $out_dir/$name ($(du -h "$out_dir/$name" | cut -f1)), validated by Blender's extension tool"
done
