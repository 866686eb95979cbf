#!/usr/bin/env bash
# The Python package's tests (scripts/test.sh calls this after cargo test).
# The extension is the cdylib cargo builds for crates/csrbf-py in the same
# run as the Rust tests (`cargo build --workspace --all-targets`: the same
# package selection and features as `cargo test --workspace`, so no
# dependency is compiled twice; a maturin build of the crate alone unifies
# features differently and recompiles faer and its kin). It is laid out as
# maturin lays it out (python/csrbf + _csrbf.abi3.so) and packed into
# target/py-wheels/csrbf-*.whl (scripts/pack_wheel.py), which is installed
# into a reusable venv (.venv-py/, packages installed only when the
# requirements change); pytest runs the suite against target/debug/csrbf,
# then the smoke tests under numpy 1.26.4 (Blender's) in .venv-py-np126/.
# `pip install crates/csrbf-py` (maturin, release) is the users' path.
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

install() { # install VENV: the wheel, and nothing else from PyPI
  "$1/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$wheel"
  "$1/bin/python" -c 'import csrbf, numpy; print(f"python tests: csrbf {csrbf.__version__} ({csrbf.build_profile} build) from {csrbf.__file__}, numpy {numpy.__version__}")'
}

# A Python extension does not link libpython (pyo3 reads this).
export PYO3_BUILD_EXTENSION_MODULE=1
# Nothing to do after scripts/test.sh's cargo test but csrbf-py's cdylib (and
# the CLI the tests compare with, when this script runs alone).
cargo build -q --workspace --all-targets --locked
rm -rf target/py-test target/py-wheels && mkdir -p target/py-test
cp -r crates/csrbf-py/python/csrbf target/py-test/
cp target/debug/lib_csrbf.so target/py-test/csrbf/_csrbf.abi3.so
version=$(sed -n 's/^version = "\(.*\)"/\1/p' Cargo.toml | head -1)
wheel=$("$py" scripts/pack_wheel.py target/py-test "$version" target/py-wheels)
export CSRBF_BIN="$PWD/target/debug/csrbf"
# The wheel is cargo's dev build; the suite checks the module says so.
export CSRBF_EXPECT_BUILD_PROFILE=dev

venv .venv-py "$tests/requirements.txt"
install .venv-py
# pytest exits 5 when it collects no test: set -e fails the run then.
.venv-py/bin/python -m pytest -q -p no:cacheprovider "$tests"

# Blender ships numpy 1.26, which has wheels up to CPython 3.12 only.
if "$py" -c 'import sys; sys.exit(sys.version_info >= (3, 13))'; then
  venv .venv-py-np126 "$tests/requirements-numpy126.txt"
  install .venv-py-np126
  # The smoke files import numpy and csrbf only (no pyvista, no dask).
  .venv-py-np126/bin/python -m pytest -q -p no:cacheprovider -m smoke \
    "$tests/test_deformation.py" "$tests/test_system.py"
else
  echo "python tests: numpy 1.26 smoke run skipped: $("$py" --version) has no numpy 1.26 wheel (needs 3.12 or older)"
fi
