#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job: the paper's sim2sim experiments (tracking, push grid,
# command noise) for the bundled O, C and C+A policies, printed beside the paper's numbers, with the heatmaps
# written to out/ablation/. Extra arguments go to `topa ablate` (e.g. --full for the paper's whole protocol).
set -euo pipefail
cd "$(dirname "$0")"
. scripts/setup.sh
cargo build --release --quiet
p=assets/policies
if [ -f $p/O.json ] && [ -f $p/C.json ] && [ -f $p/CA.json ]; then
  exec ./target/release/topa ablate --o $p/O.json --c $p/C.json --ca $p/CA.json --out out/ablation "$@"
fi
echo "no bundled policies yet: showing the two robot models instead" >&2
./target/release/topa info assets/mjcf/topa_closed.xml
./target/release/topa info assets/mjcf/topa_open.xml
