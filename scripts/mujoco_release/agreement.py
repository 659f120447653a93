#!/usr/bin/env python3
"""Each policy's tracking experiment in MuJoCo 2.2 (`topa eval tracking`) and in MuJoCo's current release
(eval_tracking.py, driven by the exported ONNX), side by side: agreement.md and agreement.json in --out.

    bash scripts/mujoco_release/install.sh
    .venv-mujoco-release/bin/python scripts/mujoco_release/agreement.py --out docs/results/mujoco_release \
        assets/policies/C assets/policies/CA

A policy passes in the release when it falls on none of the six commands and its worst component MAE (the largest
whole-window error of v_x, v_y, w_z over the commands, as `topa ablate` reports it) is within max(20 %, 0.03) of
MuJoCo 2.2's. Both evaluators run the same starts (the Rust batch's seeded initial states).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

HERE = Path(__file__).resolve().parent
REL_TOL, ABS_TOL = 0.20, 0.03


def bound(ours: float) -> float:
    """The allowed difference from MuJoCo 2.2's worst component MAE."""
    return max(REL_TOL * ours, ABS_TOL)


def worst(rows) -> tuple[str, float]:
    """The largest whole-window component MAE over the commands, with its command (claims.rs worst_component)."""
    return max(((r["key"], m) for r in rows for m in r["mae_whole"]), key=lambda x: x[1], default=("", 0.0))


def policies(paths: list[str]) -> list[Path]:
    out = []
    for p in map(Path, paths):
        if p.is_dir():
            out += sorted(p.glob("*.json"))
        elif p.suffix == ".json" and p.is_file():
            out.append(p)
        else:
            raise SystemExit(f"agreement.py: {p} is neither a policy sidecar (.json) nor a folder of them")
    if not out:
        raise SystemExit("agreement.py: no policy given")
    return out


def spec_of(sidecar: Path) -> str:
    """The robot the policy runs on: the spec its sidecar names, or the closed robot that spec `approximates` (O)."""
    robot = json.loads(sidecar.read_text()).get("robot")
    if not robot:
        raise SystemExit(f"agreement.py: {sidecar} names no robot; is it a policy sidecar?")
    with open(robot, "rb") as f:
        approximates = tomllib.load(f).get("approximates")
    return str(Path(robot).parent / approximates) if approximates else robot


def run(cmd: list[str]) -> str:
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"agreement.py: `{' '.join(cmd)}` failed:\n{r.stderr.strip()}")
    return r.stdout


def one(topa: str, sidecar: Path, args, tmp: Path) -> dict:
    onnx = tmp / (sidecar.parent.name + "_" + sidecar.stem + ".onnx")
    run([topa, "export", "--policy", str(sidecar), "--onnx", str(onnx), "--motor-targets"])
    common = ["--starts", str(args.starts), "--seconds", str(args.seconds), "--seed", str(args.seed)]
    ours = json.loads(run([topa, "eval", "tracking", "--policy", str(sidecar), "--threads", "1", "--json",
                           "--out", str(tmp / "eval")] + common))
    release_json = tmp / (onnx.stem + "_release.json")
    run([sys.executable, str(HERE / "eval_tracking.py"), "--onnx", str(onnx), "--spec", spec_of(sidecar),
         "--policy-json", str(sidecar), "--json", str(release_json)] + common)
    theirs = json.loads(release_json.read_text())
    (wk, w22), (rk, wrel) = worst(ours), worst(theirs["rows"])
    falls22 = sum(r.get("falls", int(r["fell"])) for r in ours)
    falls_rel = sum(r["falls"] for r in theirs["rows"])
    within = abs(wrel - w22) <= bound(w22)
    return {
        "policy": str(sidecar),
        "falls_22": falls22,
        "falls_release": falls_rel,
        "runs": sum(r["starts"] for r in theirs["rows"]),
        "worst_22": w22,
        "worst_22_command": wk,
        "worst_release": wrel,
        "worst_release_command": rk,
        "bound": bound(w22),
        "within": within,
        "passes": falls_rel == 0 and within,
        "per_command": [
            {"key": a["key"], "mae_whole_22": a["mae_whole"], "mae_whole_release": b["mae_whole"],
             "falls_22": a.get("falls", int(a["fell"])), "falls_release": b["falls"]}
            for a, b in zip(ours, theirs["rows"])
        ],
        "mujoco_warnings": theirs["mujoco_warnings"],
        "release": theirs["mujoco"],
    }


def markdown(rows: list[dict], args) -> str:
    release = rows[0]["release"] if rows else "?"
    lines = [
        f"# Tracking in MuJoCo 2.2 and MuJoCo {release}",
        "",
        f"The six tracking commands, {args.starts} start(s) × {args.seconds:g} s each (seed {args.seed}), run by "
        f"`topa eval tracking` (MuJoCo 2.2, Rust) and by `scripts/mujoco_release/eval_tracking.py` (MuJoCo {release}'s "
        "official Python bindings, the exported ONNX, the observation and PD loop written again from "
        "docs/deployment.md). Worst component MAE: the largest whole-window error of v_x, v_y, w_z over the commands. "
        f"A policy passes in the release with no fall and a worst MAE within max({REL_TOL:.0%}, {ABS_TOL}) of 2.2's.",
        "",
        f"Made by `scripts/mujoco_release/agreement.py --starts {args.starts} --seconds {args.seconds:g} "
        f"{' '.join(args.policies)}`.",
        "",
        f"| policy | falls 2.2 | falls {release} | worst MAE 2.2 | worst MAE {release} | difference | bound | passes |",
        "|---|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        d = r["worst_release"] - r["worst_22"]
        lines.append(
            f"| {r['policy']} | {r['falls_22']}/{r['runs']} | {r['falls_release']}/{r['runs']} | "
            f"{r['worst_22']:.3f} ({r['worst_22_command']}) | {r['worst_release']:.3f} ({r['worst_release_command']}) | "
            f"{d:+.3f} | {r['bound']:.3f} | {'yes' if r['passes'] else '**no**'} |")
    failed = [r["policy"] for r in rows if not r["passes"]]
    lines += ["", f"{len(rows) - len(failed)} of {len(rows)} policies pass"
              + (f"; not: {', '.join(failed)}." if failed else ".")]
    return "\n".join(lines) + "\n"


def write_atomic(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("policies", nargs="+", help="policy sidecars (.json) or folders of them")
    p.add_argument("--topa", default=None,
                   help="the topa binary (default: the repository's target/release/topa if built, else topa on the PATH)")
    p.add_argument("--starts", type=int, default=3, help="initial states per command (default 3)")
    p.add_argument("--seconds", type=float, default=10.0, help="window per command, s (default 10)")
    p.add_argument("--seed", type=int, default=1, help="seed of the starts (default 1)")
    p.add_argument("--out", default="out/mujoco_release", help="folder for agreement.md and agreement.json")
    args = p.parse_args()
    if args.topa is None:
        built = HERE.parents[1] / "target" / "release" / "topa"
        args.topa = str(built) if built.exists() else "topa"
    if args.starts < 1 or args.seconds <= 0:
        raise SystemExit("agreement.py: --starts must be >= 1 and --seconds > 0")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for sidecar in policies(args.policies):
            r = one(args.topa, sidecar, args, Path(tmp))
            print(f"{r['policy']}: falls {r['falls_22']}/{r['falls_release']}, worst {r['worst_22']:.3f} / "
                  f"{r['worst_release']:.3f}, {'passes' if r['passes'] else 'FAILS'}", flush=True)
            rows.append(r)
    md = markdown(rows, args)
    meta = {"starts": args.starts, "seconds": args.seconds, "seed": args.seed, "rel_tol": REL_TOL,
            "abs_tol": ABS_TOL, "policies": rows}
    write_atomic(out / "agreement.json", json.dumps(meta, indent=2) + "\n")
    write_atomic(out / "agreement.md", md)
    print(md)


if __name__ == "__main__":
    main()
