#!/usr/bin/env bash
# The Python package's tests (scripts/test.sh calls this after cargo test).
# Builds crates/csrbf-py in the dev profile, whose dependencies cargo test
# has already built (optimised), installs the wheel into a reusable venv
# (.venv-py/; packages installed only when the requirements change) and runs
# pytest, then the smoke tests under numpy 1.26.4 (Blender's) in .venv-py-np126/.
set -euo pipefail
cd "$(dirname "$0")/.."
py="${PYTHON:-python3}"
tests=crates/csrbf-py/tests

venv() { # venv DIR REQUIREMENTS: made and filled only when missing or changed
  local dir=$1 req=$2
  [ -x "$dir/bin/python" ] || "$py" -m venv "$dir"
  if ! cmp -s "$req" "$dir/.requirements"; then
    echo "python tests: installing $(grep -v '^#' "$req" | tr '\n' ' ')into $dir"
    "$dir/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
    cp "$req" "$dir/.requirements"
  fi
}

venv .venv-py "$tests/requirements.txt"
# The CLI the tests compare with: cargo test built it; building it alone
# would unify features differently and recompile dependencies.
[ -x target/debug/csrbf ] || cargo build -q -p csrbf-cli --locked
rm -rf target/py-wheels
.venv-py/bin/maturin build -q --profile dev --locked -m crates/csrbf-py/Cargo.toml \
  -i .venv-py/bin/python -o target/py-wheels
wheel=$(ls target/py-wheels/csrbf-*.whl)
.venv-py/bin/python -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
export CSRBF_BIN="$PWD/target/debug/csrbf"
# pytest exits 5 when it collects no test: set -e fails the run then.
.venv-py/bin/python -m pytest -q -p no:cacheprovider "$tests"

# Blender ships numpy 1.26, which has wheels up to CPython 3.12 only.
if "$py" -c 'import sys; sys.exit(sys.version_info >= (3, 13))'; then
  venv .venv-py-np126 "$tests/requirements-numpy126.txt"
  .venv-py-np126/bin/python -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
  # The smoke files import numpy and csrbf only (no pyvista, no dask).
  .venv-py-np126/bin/python -m pytest -q -p no:cacheprovider -m smoke \
    "$tests/test_deformation.py" "$tests/test_system.py"
else
  echo "python tests: numpy 1.26 smoke run skipped: $("$py" --version) has no numpy 1.26 wheel (needs 3.12 or older)"
fi
