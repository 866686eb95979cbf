#!/usr/bin/env bash
# Installs the csrbf wheel for this machine from DIR as a user without a Rust
# toolchain or a C compiler does, and runs it:
#
#   scripts/release/python_install_test.sh DIR [release|dev]
#
# A fresh venv gets numpy and pytest from PyPI, then csrbf with
# `pip install --no-index --find-links DIR csrbf` (timed) under a PATH that
# holds the venv's own programs only: no cargo, no rustc, no cc, so a wheel
# that did not fit this machine would fail rather than be compiled. Then the
# README's Python example runs (the first python block of its "Python"
# section, beside the bundled assets) and the package's smoke tests.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$PWD
dir=$(realpath "$1")
profile=${2:-}
py="${PYTHON:-python3}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$py" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --disable-pip-version-check numpy pytest
for tool in cargo rustc cc gcc; do
  if PATH="$work/venv/bin" command -v "$tool" >/dev/null 2>&1; then
    echo "python install test: $tool is on the install's PATH" >&2
    exit 1
  fi
done
start=$(date +%s%N)
env -i HOME="$work" PATH="$work/venv/bin" "$work/venv/bin/python" -m pip install -q --disable-pip-version-check \
  --no-index --find-links "$dir" csrbf
took=$(( ($(date +%s%N) - start) / 1000000 ))
"$work/venv/bin/python" -c 'import csrbf, sys; print(f"python install test: csrbf {csrbf.__version__} ({csrbf.build_profile}) installed from '"$dir"' in '"$took"' ms, no compiler on PATH; {csrbf.__file__}")'
# The README's example, where its relative paths resolve (assets/), in a folder of its own.
mkdir -p "$work/example"
ln -s "$PWD/assets" "$work/example/assets"
"$py" - README.md > "$work/example/example.py" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
section = text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
blocks = re.findall(r"```python\n(.*?)```", section, re.S)
if not blocks:
    sys.exit("python install test: the README's Python section has no python block")
print(blocks[0])
PY
(cd "$work/example" && "$work/venv/bin/python" example.py)
echo "python install test: the README's Python example ran"
export CSRBF_EXPECT_BUILD_PROFILE="$profile"
(cd "$work" && "$work/venv/bin/python" -m pytest -q -p no:cacheprovider -m smoke \
  "$root/crates/csrbf-py/tests/test_deformation.py" "$root/crates/csrbf-py/tests/test_system.py")
