#!/usr/bin/env bash
# Trains the shipped seeds of a preset — C 1–5, O 1–3, then C+A 1–5, each C+A forked from the C of its seed — into
# run folders under RUNS, one after another, each on every core. A run an earlier call left unfinished is resumed
# from its latest checkpoint and a finished one is skipped, so the call can be repeated until everything is done
# (a session that ends mid-run loses at most one checkpoint interval). With --ship the finished runs are then
# copied into assets/policies/{C,O,CA}/seedN (scripts/ship_policy.py: provenance kept, paths cleaned).
# Usage: scripts/train_seeds.sh CONFIG RUNS [--ship] [RUN …]   RUN: C1 … C5, O1 … O3, CA1 … CA5 (default: all)
# Environment: TOPA (the binary; default target/release/topa), THREADS (default 0 = all cores).
set -euo pipefail
usage="usage: scripts/train_seeds.sh CONFIG RUNS [--ship] [RUN …]   (e.g. configs/cpu.toml ~/runs C1 C2)"
[ $# -ge 2 ] || { echo "$usage" >&2; exit 2; }
config=$1 runs=$2
shift 2
ship=0
if [ "${1:-}" = --ship ]; then ship=1; shift; fi
[ -f "$config" ] || { echo "$config: no such preset (see configs/)" >&2; exit 2; }
here=$(cd "$(dirname "$0")/.." && pwd)
topa=${TOPA:-$here/target/release/topa}
[ -x "$topa" ] || { echo "$topa: not built (cargo build --release), or set TOPA" >&2; exit 2; }
threads=${THREADS:-0}
all="C1 C2 C3 C4 C5 O1 O2 O3 CA1 CA2 CA3 CA4 CA5"
wanted=${*:-$all}
mkdir -p "$runs"

for run in $wanted; do
    group=${run%%[0-9]*} seed=${run#"$group"}
    case "$group" in
        C) start=(--config "$config" --model closed --seed "$seed") ;;
        O) start=(--config "$config" --model open --seed "$seed") ;;
        CA)
            [ -f "$runs/C-s$seed/policy.json" ] || { echo "$run needs $runs/C-s$seed first (run C$seed)" >&2; exit 1; }
            start=(--config "$config" --adversary --init-from "$runs/C-s$seed" --seed "$seed") ;;
        *) echo "$run: not one of $all" >&2; exit 2 ;;
    esac
    [[ "$seed" =~ ^[1-9][0-9]*$ ]] || { echo "$run: no seed number (e.g. C1)" >&2; exit 2; }
    out="$runs/$group-s$seed"
    if [ -f "$out/checkpoints/latest.json" ]; then
        echo "== $run: resuming $out" >&2
        "$topa" train --resume "$out" --threads "$threads" --quiet >>"$out.log" 2>&1
    else
        echo "== $run: training into $out" >&2
        rm -rf "$out"   # a start that wrote no checkpoint yet has nothing to keep
        "$topa" train "${start[@]}" --threads "$threads" --quiet --out "$out" >"$out.log" 2>&1
    fi
    if [ "$ship" = 1 ]; then
        python3 "$here/scripts/ship_policy.py" "$out" "$group/seed$seed"
    fi
done
