#!/usr/bin/env bash
# Installs the csrbf wheel for this machine from DIR as a user without a Rust
# toolchain or a C compiler does, and runs it:
#
#   scripts/release/python_install_test.sh DIR [release|dev]
#
# A fresh venv gets numpy and pytest from PyPI, then csrbf with
# `pip install --no-index --find-links DIR csrbf` (timed) in an empty
# environment (`env -i`) whose PATH is the venv's bin alone: no cargo, no
# rustc, no cc, and no index to fetch an sdist from, so a wheel that did not
# fit this machine fails rather than being compiled. Then the guide's
# Python example runs (the first python block of docs/python.md, beside the
# bundled assets) and the package's smoke tests.
set -euo pipefail
dir=$(realpath "$1")
cd "$(dirname "$0")/../.."
root=$PWD
profile=${2:-}
py="${PYTHON:-python3}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$py" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --disable-pip-version-check numpy pytest
start=$(date +%s%N)
env -i HOME="$work" PATH="$work/venv/bin" "$work/venv/bin/python" -m pip install -q --disable-pip-version-check \
  --no-index --find-links "$dir" csrbf
took=$(( ($(date +%s%N) - start) / 1000000 ))
"$work/venv/bin/python" -c 'import csrbf, sys; print(f"python install test: csrbf {csrbf.__version__} ({csrbf.build_profile}) installed from '"$dir"' in '"$took"' ms, no compiler on PATH; {csrbf.__file__}")'
# The guide's example, where its relative paths resolve (assets/), in a folder of its own.
mkdir -p "$work/example"
ln -s "$PWD/assets" "$work/example/assets"
"$py" - docs/python.md > "$work/example/example.py" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
blocks = re.findall(r"```python\n(.*?)```", text, re.S)
if not blocks:
    sys.exit("python install test: docs/python.md has no python block")
print(blocks[0])
PY
(cd "$work/example" && "$work/venv/bin/python" example.py)
echo "python install test: the guide's Python example ran"
export CSRBF_EXPECT_BUILD_PROFILE="$profile"
(cd "$work" && "$work/venv/bin/python" -m pytest -q -p no:cacheprovider -m smoke \
  "$root/crates/csrbf-py/tests/test_deformation.py" "$root/crates/csrbf-py/tests/test_system.py")
