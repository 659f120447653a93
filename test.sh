#!/usr/bin/env bash
# Installs what is missing, then runs every test of the workspace (release build: the physics tests need it).
set -euo pipefail
cd "$(dirname "$0")"
. scripts/setup.sh
cargo test --release --workspace "$@"
