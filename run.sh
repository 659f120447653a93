#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job: the paper's sim2sim experiments (tracking, push grid,
# command noise) for the shipped seeds of O, C and C+A (assets/policies/{O,C,CA}/), each group's mean with its
# 95 % interval beside the paper's numbers and the claims checked, the report and heatmaps written to
# out/ablation/. The quick protocol by default; extra arguments go to `topa ablate` (--full: the paper's protocol).
set -euo pipefail
cd "$(dirname "$0")"
. scripts/setup.sh
cargo build --release --quiet
topa="${CARGO_TARGET_DIR:-target}/release/topa"   # where cargo put it, also with a custom target folder
p=assets/policies
exec "$topa" ablate --o $p/O --c $p/C --ca $p/CA --out out/ablation "$@"
