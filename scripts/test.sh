#!/usr/bin/env bash
# Runs every test in the dev profile (a release test build recompiles every
# dependency). The real models are read from ../shared/models when present,
# else from assets/models.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace --locked
