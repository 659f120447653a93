#!/usr/bin/env bash
# Starts one training per "NAME=CONFIG[:SEED]" argument, each in its own process session (so that it outlives the
# command that started it) with THREADS threads, run folders under RUNS. Used for lever sweeps on the 16-core
# machine (with the bundle of bundle.sh) and for seed trainings here. Re-running it resumes every run that has a
# checkpoint. Environment: RUNS (default runs/sweep), THREADS (default 2), TOPA (default: the bundle's launcher
# if present, else target/release/topa), EXTRA (more arguments for new runs, e.g. "--model open"; {seed} stands for
# the run's seed: "--adversary --init-from .device/init/C-{seed}" forks each seed's C into the adversary).
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=scripts/device/unpack.sh
source scripts/device/unpack.sh
runs="${RUNS:-runs/sweep}"
threads="${THREADS:-2}"
extra="${EXTRA:-}"
if [ -z "${TOPA:-}" ]; then
  if [ -x .device/bundle/run ]; then TOPA=".device/bundle/run topa"; else TOPA="${CARGO_TARGET_DIR:-target}/release/topa"; fi
fi
mkdir -p "$runs"
for spec in "$@"; do
  name="${spec%%=*}"; rest="${spec#*=}"; cfg="${rest%%:*}"; seed=1
  [ "$rest" != "$cfg" ] && seed="${rest#*:}"
  dir="$runs/$name"
  if [ -e "$dir/checkpoints/latest.json" ]; then
    args=(train --resume "$dir" --threads "$threads" --quiet)
  else
    # shellcheck disable=SC2206
    args=(train --config "$cfg" --seed "$seed" --out "$dir" --threads "$threads" --quiet ${extra//\{seed\}/$seed})
  fi
  # shellcheck disable=SC2086
  setsid nohup $TOPA "${args[@]}" >>"$runs/$name.log" 2>&1 < /dev/null &
  echo "$name: $TOPA ${args[*]}"
done
