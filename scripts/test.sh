#!/usr/bin/env bash
# Every test, in the dev profile (a release test build recompiles every
# dependency). Installs what the tests need first (scripts/setup.sh --tests).
# The Python package (crates/csrbf-py) is tested by pytest, not cargo test:
# scripts/test_python.sh builds it into a venv after the Rust tests.
# The real models are read from ../shared/models when present, else from assets/models.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --tests
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
cargo test --workspace --exclude csrbf-py --locked
scripts/test_python.sh
