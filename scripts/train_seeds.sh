#!/usr/bin/env bash
# Trains the shipped seeds of a preset — C 1–5, O 1–5, then C+A 1–5, each C+A forked from the C of its seed — into
# run folders under RUNS, and on request the terrain runs that fork from them. A run an earlier call left unfinished
# is resumed from its latest checkpoint and a finished one is skipped, so the call can be repeated until everything
# is done (a session that ends mid-run loses at most one checkpoint interval). With --ship the finished runs are then
# copied into assets/policies/GROUP/seedN (scripts/ship_policy.py: provenance kept, paths cleaned).
# LANES=N trains N runs side by side (the runs dealt out in turn, each lane on cores/N threads; a run that forks from
# another waits for it when another lane trains it): on a 2-core machine two lanes get more samples through than one
# run on both cores.
# Usage: scripts/train_seeds.sh CONFIG RUNS [--ship] [RUN …]   RUN (default: the flat ones):
#   C1 … C5, O1 … O5, CA1 … CA5          the flat groups on CONFIG (CA<N> forks from C<N>)
#   C-terrainN, O-terrainN                C<N> / O<N> continued on the terrain preset (TERRAIN_CONFIG)
#   CA-terrainN                           C-terrain<N> forked into the terrain preset's adversary cycles
#   C-terrain-scanN, C-terrain-blindN     C-terrain<N> forked with the height scan (SCAN_CONFIG), and the blind
#                                         control of as many iterations (shipped as C-terrain-scan/blind/seedN)
# Environment: TOPA (the binary; default target/release/topa), LANES (default 1), THREADS (per lane; default
# cores/LANES, 0 = all cores), TERRAIN_CONFIG and SCAN_CONFIG (default terrain.toml and terrain-scan.toml beside
# CONFIG; their base chain should lead to CONFIG).
set -euo pipefail
usage="usage: scripts/train_seeds.sh CONFIG RUNS [--ship] [RUN …]   (e.g. configs/cpu.toml ~/runs C1 C2 C-terrain1)"
[ $# -ge 2 ] || { echo "$usage" >&2; exit 2; }
config=$1 runs=$2
shift 2
ship=0
if [ "${1:-}" = --ship ]; then ship=1; shift; fi
[ -f "$config" ] || { echo "$config: no such preset (see configs/)" >&2; exit 2; }
here=$(cd "$(dirname "$0")/.." && pwd)
topa=${TOPA:-$here/target/release/topa}
[ -x "$topa" ] || { echo "$topa: not built (cargo build --release), or set TOPA" >&2; exit 2; }
all="C1 C2 C3 C4 C5 O1 O2 O3 O4 O5 CA1 CA2 CA3 CA4 CA5"
groups="C O CA C-terrain O-terrain CA-terrain C-terrain-scan C-terrain-blind"
read -r -a wanted <<<"${*:-$all}"
terrain_config=${TERRAIN_CONFIG:-$(dirname "$config")/terrain.toml}
scan_config=${SCAN_CONFIG:-$(dirname "$config")/terrain-scan.toml}
lanes=${LANES:-1}
[[ "$lanes" =~ ^[1-9][0-9]*$ ]] || { echo "LANES=$lanes: give a number of lanes ≥ 1" >&2; exit 2; }

# What a run of group $1 forks from (a group of the same seed), the presets it reads, and how it starts (the blind
# control: the blind terrain preset for $scan_iters iterations, the scan preset's run).
plan() {
    case "$1" in
        C) from="" reads=("$config") start=(--config "$config" --model closed) ;;
        O) from="" reads=("$config") start=(--config "$config" --model open) ;;
        CA) from=C reads=("$config") start=(--config "$config" --adversary) ;;
        C-terrain) from=C reads=("$terrain_config") start=(--config "$terrain_config") ;;
        O-terrain) from=O reads=("$terrain_config") start=(--config "$terrain_config" --model open) ;;
        CA-terrain) from=C-terrain reads=("$terrain_config") start=(--config "$terrain_config" --adversary) ;;
        C-terrain-scan) from=C-terrain reads=("$scan_config") start=(--config "$scan_config") ;;
        C-terrain-blind)
            from=C-terrain reads=("$terrain_config" "$scan_config")
            start=(--config "$terrain_config" --iterations "${scan_iters:-}") ;;
        *) return 1 ;;
    esac
}

# Every name is checked before anything trains, so a typo does not surface hours later.
for run in "${wanted[@]}"; do
    group=${run%%[0-9]*} seed=${run#"$group"}
    plan "$group" || { echo "$run: not a group of seeds (one of: $groups; e.g. C1)" >&2; exit 2; }
    [[ "$seed" =~ ^[1-9][0-9]*$ ]] || { echo "$run: no seed number (e.g. C1)" >&2; exit 2; }
    for f in "${reads[@]}"; do
        [ -f "$f" ] || { echo "$run: $f: no such preset (set TERRAIN_CONFIG / SCAN_CONFIG)" >&2; exit 2; }
    done
done
mkdir -p "$runs"

if [ "$lanes" -gt 1 ]; then
    cores=$(nproc)
    export TOPA=$topa LANES=1 THREADS=${THREADS:-$((cores / lanes > 0 ? cores / lanes : 1))}
    export TRAIN_SEEDS_ALL="${wanted[*]}"   # what the lanes train between them (see the C+A's wait below)
    flags=()
    [ "$ship" = 1 ] && flags=(--ship)
    pids=()
    for ((l = 0; l < lanes; l++)); do
        mine=()
        for ((i = l; i < ${#wanted[@]}; i += lanes)); do mine+=("${wanted[i]}"); done
        [ ${#mine[@]} -gt 0 ] || continue
        echo "== lane $((l + 1)): ${mine[*]}" >&2
        "$0" "$config" "$runs" "${flags[@]}" "${mine[@]}" &
        pids+=($!)
    done
    # The first lane to fail stops the others (a C+A waiting on a C that failed would wait for ever).
    for _ in "${pids[@]}"; do
        if ! wait -n; then
            echo "a lane failed: stopping the others (its run's log under $runs says why)" >&2
            for p in "${pids[@]}"; do pkill -TERM -P "$p" 2>/dev/null || true; kill "$p" 2>/dev/null || true; done
            wait || true
            exit 1
        fi
    done
    exit 0
fi

# Whether the plain run in folder $1 has reached its length (its policy.json is exported at every checkpoint, so
# its presence alone says nothing).
finished() {
    python3 - "$1/checkpoints" <<'EOF'
import json, sys
from pathlib import Path
d = Path(sys.argv[1])
try:
    side = json.loads((d / json.loads((d / "latest.json").read_text())["sidecar"]).read_text())
except (OSError, ValueError, KeyError):
    sys.exit(1)
sys.exit(0 if side["iteration"] >= side["config"]["run"]["iterations"] else 1)
EOF
}

threads=${THREADS:-0}
for run in "${wanted[@]}"; do
    group=${run%%[0-9]*} seed=${run#"$group"}
    if [ "$group" = C-terrain-blind ]; then
        scan_iters=$("$topa" config show "$scan_config" | python3 -c \
            'import sys, tomllib; print(tomllib.loads(sys.stdin.read())["run"]["iterations"])')
    fi
    plan "$group"
    if [ -n "$from" ]; then
        c="$runs/$from-s$seed"
        # In a lane, wait for a run that another lane trains (one later in this lane would never come).
        if ! finished "$c" && [[ " ${TRAIN_SEEDS_ALL:-} " == *" $from$seed "* && " ${wanted[*]} " != *" $from$seed "* ]]
        then
            echo "== $run: waiting for $c to finish" >&2
            until finished "$c"; do sleep "${TRAIN_SEEDS_POLL_S:-30}"; done
        fi
        finished "$c" || { echo "$run needs a finished $c first (run $from$seed)" >&2; exit 1; }
        start+=(--init-from "$c")
    fi
    start+=(--seed "$seed")
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
        dest=$group/seed$seed
        [ "$group" = C-terrain-blind ] && dest=C-terrain-scan/blind/seed$seed
        python3 "$here/scripts/ship_policy.py" "$out" "$dest"
    fi
done
