#!/usr/bin/env bash
# Installs what is missing (Open MPI included), then runs every test of the workspace, the multi-rank training
# tests too (release build: the physics tests need it).
set -euo pipefail
cd "$(dirname "$0")"
TOPA_MPI=1 . scripts/setup.sh
cargo test --release --workspace --features topa/mpi "$@"
