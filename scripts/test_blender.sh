#!/usr/bin/env bash
# The Blender extension's tests (scripts/test.sh calls this after the Python
# package's): headless Blender (the bpy module, about 375 MB) in a venv kept
# in the user's cache, so it is downloaded once per machine; the csrbf wheel
# scripts/test_python.sh built is installed into it. Also packs the
# extension's zip with that wheel (under target/, never dist/) and checks
# what Blender will read in it.
set -euo pipefail
cd "$(dirname "$0")/.."
py="${PYTHON:-python3}"
if ! "$py" -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))'; then
  echo "blender tests: bpy 5.0.1 needs CPython 3.11, this is $("$py" --version)" >&2
  exit 1
fi
venv="${CSRBF_BLENDER_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/csrbf/venv-blender}"
req=blender/requirements.txt
[ -x "$venv/bin/python" ] || { mkdir -p "$(dirname "$venv")"; "$py" -m venv "$venv"; }
if ! cmp -s "$req" "$venv/.requirements"; then
  echo "blender tests: installing $(grep -v '^#' "$req" | tr '\n' ' ')into $venv"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
  cp "$req" "$venv/.requirements"
fi
wheel=$(ls target/py-wheels/csrbf-*.whl)
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
"$venv/bin/python" -m pytest -q -p no:cacheprovider blender/tests
# Packed apart from dist/ (where users' release zip goes): the tests' wheel is
# a dev build, slower, and must not pass for the one to install.
rm -rf target/blender-ext-test
scripts/build-blender-extension.sh --wheel "$wheel" --out target/blender-ext-test
zip=$(ls target/blender-ext-test/csrbf_blender-*.zip)
# Blender's own extension tool (shipped in bpy) validates the zip as Blender
# does before installing it.
ext_cli=$(ls "$venv"/lib/python3*/site-packages/bpy/*/scripts/addons_core/bl_pkg/cli/blender_ext.py)
"$venv/bin/python" "$ext_cli" validate "$zip"
"$venv/bin/python" - "$zip" "$ext_cli" <<'PY'
import importlib.util, sys, tomllib, zipfile
z = zipfile.ZipFile(sys.argv[1])
names = set(z.namelist())
manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
assert manifest["schema_version"] and manifest["blender_version_min"] == "4.2.0", manifest
for w in manifest["wheels"]:
    assert w.removeprefix("./") in names, (w, names)
assert {"__init__.py", "operators.py", "core.py", "live.py", "ui.py", "props.py"} <= names, names
# Blender reads an abi3 wheel as fit for every CPython 3 (4.2-5.0's 3.11, 5.1's 3.13).
spec = importlib.util.spec_from_file_location("blender_ext", sys.argv[2])
ext = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ext)
versions = ext.python_versions_from_wheel(manifest["wheels"][0].rsplit("/", 1)[-1])
assert versions == {(3,)}, versions
print(f"blender tests: {sys.argv[1]} holds the manifest, the add-on and {manifest['wheels'][0]} (Python versions {versions})")
PY
# Blender installs the zip as a user would (Install from Disk), wheel and
# all, and its operators run: in a throwaway home, so nothing of the user's
# Blender is touched.
home=$(mktemp -d)
HOME="$home" "$venv/bin/python" - "$PWD/$zip" <<'PY'
import sys, bpy
assert bpy.ops.extensions.package_install_files(
    filepath=sys.argv[1], repo="user_default", enable_on_install=True) == {"FINISHED"}
assert "bl_ext.user_default.csrbf" in sys.modules, "the extension did not load"
bpy.ops.mesh.primitive_uv_sphere_add()
bpy.context.scene.cursor.location = (0, 0, 1.5)
assert bpy.ops.csrbf.add_control() == {"FINISHED"}
print("blender tests: Blender installed and enabled the packed extension; csrbf.add_control ran")
PY
rm -rf "$home"
