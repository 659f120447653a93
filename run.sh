#!/usr/bin/env bash
# Installs what is missing, builds `topa` and puts it on the PATH (`cargo install --path .`, into Cargo's bin
# folder), then runs the main job: the paper's sim2sim experiments (tracking, push grid, command noise) for the
# shipped seeds of O, C and C+A (assets/policies/{O,C,CA}/), each group's mean with its 95 % interval beside the
# paper's numbers and the claims checked, the report and heatmaps written to out/ablation/. The quick protocol by
# default; extra arguments go to `topa ablate` (--full: the paper's protocol).
set -euo pipefail
cd "$(dirname "$0")"
. scripts/setup.sh
# The release build in this tree's target folder, copied to Cargo's bin folder (rustup puts it on the PATH).
cargo install --path . --locked --force --quiet
bin="${CARGO_INSTALL_ROOT:-${CARGO_HOME:-$HOME/.cargo}}/bin"
echo "topa installed in $bin: \`topa view\` shows TopA walking (run it in another terminal while this goes on)"
command -v topa >/dev/null 2>&1 || echo "run.sh: $bin is not on your PATH: add it (rustup's ~/.profile line does)" >&2
p=assets/policies
exec "$bin/topa" ablate --o $p/O --c $p/C --ca $p/CA --out out/ablation "$@"
