#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job: the paper's sim2sim experiments (tracking, push grid,
# command noise) for the shipped seeds of O, C and C+A (assets/policies/{O,C,CA}/, the current preset), each group's
# mean ± sd printed beside the paper's numbers, with the heatmaps written to out/ablation/. Extra arguments go to
# `topa ablate` (e.g. --full for the paper's whole protocol).
set -euo pipefail
cd "$(dirname "$0")"
. scripts/setup.sh
cargo build --release --quiet
topa="${CARGO_TARGET_DIR:-target}/release/topa"   # where cargo put it, also with a custom target folder
p=assets/policies
if [ -d $p/O ] && [ -d $p/C ] && [ -d $p/CA ]; then
  exec "$topa" ablate --o $p/O --c $p/C --ca $p/CA --out out/ablation "$@"
fi
if [ -f $p/O.json ] && [ -f $p/C.json ] && [ -f $p/CA.json ]; then
  exec "$topa" ablate --o $p/O.json --c $p/C.json --ca $p/CA.json --out out/ablation "$@"
fi
echo "no bundled policies yet: showing the two robot models instead" >&2
"$topa" info assets/mjcf/topa_closed.xml
"$topa" info assets/mjcf/topa_open.xml
