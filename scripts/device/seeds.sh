#!/usr/bin/env bash
# A training burst on the lent 16-core machine: starts the given runs of configs/cpu.toml ("NAME=MODEL:SEED", e.g.
# C-s4=closed:4), each with THREADS threads, lets them train for SECONDS, stops them (a run keeps its last
# checkpoint: at most checkpoint_every iterations are lost) and packs the run folders into $OUT/runs.tgz.aa, .ab, …
# (12 MB parts: a file brought back may not pass 16 MiB), to be joined here (`cat runs.tgz.* | tar xzf -`) and
# resumed with `topa train --resume`. A run folder already there (a second call on a warm machine) is resumed.
# Needs the bundle of bundle.sh (carry .device/bundle.txz, or .device where the repository is small enough).
set -uo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=scripts/device/unpack.sh
source scripts/device/unpack.sh
threads="${THREADS:-5}"; seconds="${SECONDS_TO_RUN:-500}"
lscpu | grep -E "^Model name|^CPU\(s\)"
echo "AVX-512: $(grep -o -w -E 'avx512(f|bw|vl|_bf16)' /proc/cpuinfo | sort -u | tr '\n' ' ')"
mkdir -p runs
names=(); pids=()
for spec in "$@"; do
  name="${spec%%=*}"; rest="${spec#*=}"; model="${rest%%:*}"; seed="${rest#*:}"
  if [ -e "runs/$name/checkpoints/latest.json" ]; then
    args=(--resume "runs/$name")
  else
    args=(--config configs/cpu.toml --model "$model" --seed "$seed" --out "runs/$name")
  fi
  .device/bundle/run topa train "${args[@]}" --threads "$threads" --quiet >> "runs/$name.log" 2>&1 &
  names+=("$name"); pids+=($!)
done
sleep "$seconds"
kill "${pids[@]}"; wait
for n in "${names[@]}"; do echo "$n: $(tail -1 "runs/$n.log")"; cat "runs/$n/checkpoints/latest.json" 2>/dev/null | tr -d '\n '; echo; done
tar czf - runs | split -b 12M - "$OUT/runs.tgz."
ls -la "$OUT"
