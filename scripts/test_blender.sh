#!/usr/bin/env bash
# The Blender extension's tests (scripts/test.sh calls this after the Python
# package's): headless Blender (the bpy module, about 375 MB) in a venv kept
# in the user's cache, so it is downloaded once per machine; the csrbf wheel
# scripts/test_python.sh built is installed into it. Also packs the
# extension's zip with that wheel (under target/, never dist/) and checks
# what Blender will read in it.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/blender_venv.sh
venv=$blender_venv
wheel=$(ls target/py-wheels/csrbf-*.whl)
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
"$venv/bin/python" -m pytest -q -p no:cacheprovider blender/tests
# Packed apart from dist/ (where users' release zip goes): the tests' wheel is
# a dev build, slower, and must not pass for the one to install.
rm -rf target/blender-ext-test
scripts/build-blender-extension.sh --wheel "$wheel" --out target/blender-ext-test
zip=$(ls target/blender-ext-test/csrbf-blender-*-linux_x64.zip)
# (build-blender-extension.sh had Blender's own tool validate it.)
"$venv/bin/python" - "$zip" "$blender_ext_cli" <<'PY'
import importlib.util, sys, tomllib, zipfile
z = zipfile.ZipFile(sys.argv[1])
names = set(z.namelist())
manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
assert manifest["schema_version"] and manifest["blender_version_min"] == "4.2.0", manifest
wheels = manifest["build"]["generated"]["wheels"]
assert manifest["build"]["generated"]["platforms"] == ["linux-x64"], manifest["build"]
for w in wheels:
    assert w.removeprefix("./") in names, (w, names)
assert {"__init__.py", "operators.py", "core.py", "live.py", "ui.py", "props.py"} <= names, names
# Blender reads an abi3 wheel as fit for every CPython 3 (4.2-5.0's 3.11, 5.1's 3.13).
spec = importlib.util.spec_from_file_location("blender_ext", sys.argv[2])
ext = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ext)
versions = ext.python_versions_from_wheel(wheels[0].rsplit("/", 1)[-1])
assert versions == {(3,)}, versions
print(f"blender tests: {sys.argv[1]} holds the manifest, the add-on and {wheels[0]} (Python versions {versions})")
PY
# Blender installs the zip as a user would (Install from Disk), wheel and
# all, and Deform runs with it: in a throwaway home, so nothing of the user's
# Blender is touched, and with the venv's own csrbf uninstalled (Blender has
# none), so the zip's wheel is the one imported.
"$venv/bin/python" -m pip uninstall -q -y csrbf
home=$(mktemp -d)
HOME="$home" "$venv/bin/python" scripts/release/blender_install_test.py "$PWD/$zip" --profile dev
rm -rf "$home"
