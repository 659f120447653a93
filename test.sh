#!/usr/bin/env bash
# Installs what is missing (Open MPI included), then runs every test of the workspace, the multi-rank training
# tests too (release build: the physics tests need it).
set -euo pipefail
cd "$(dirname "$0")"
TOPA_MPI=1 . scripts/setup.sh
# The second evaluator (MuJoCo's current release, from PyPI): its test says it skipped when this could not install.
bash scripts/mujoco_release/install.sh || echo "test.sh: MuJoCo's current release not installed; its test will skip" >&2
cargo test --release --workspace --features topa/mpi "$@"
