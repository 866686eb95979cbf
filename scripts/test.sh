#!/usr/bin/env bash
# Every test, in the dev profile (a release test build recompiles every
# dependency). Installs what the tests need first (scripts/setup.sh --tests).
# The real models are read from ../shared/models when present, else from assets/models.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --tests
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}"
cargo test --workspace --locked
