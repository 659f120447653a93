#!/usr/bin/env python3
"""Side by side: `topa eval tracking --json` (MuJoCo 2.2, Rust) against eval_tracking.py --json (current MuJoCo).

    topa eval tracking --policy P.json --starts 1 --seconds 5 --threads 1 --json > out/rust.json
    .venv-mujoco-release/bin/python scripts/mujoco_release/eval_tracking.py --onnx P.onnx \
        --spec assets/robots/topa_closed.toml --starts 1 --seconds 5 --json out/ours.json
    python3 scripts/mujoco_release/compare.py out/rust.json out/ours.json

Per command: falls and the whole-window MAE of v_x, v_y, w_z (the paper-comparable `mae_whole`), then the steady
MAE after the transient (`mae_components`), "2.2 / release".
"""

import json
import sys


def rows(path):
    with open(path) as f:
        d = json.load(f)
    if isinstance(d, dict):  # eval_tracking.py's report
        return d["rows"], f"MuJoCo {d['mujoco']}"
    return d, "MuJoCo 2.2 (topa)"


def main():
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    (a, la), (b, lb) = rows(sys.argv[1]), rows(sys.argv[2])
    print(f"left: {la} ({sys.argv[1]}), right: {lb} ({sys.argv[2]})")
    print(f"{'command':<14} {'falls':>5} {'whole vx':>13} {'whole vy':>13} {'whole wz':>13} | "
          f"{'steady vx':>13} {'steady vy':>13} {'steady wz':>13}")
    by_key = {r["key"]: r for r in b}
    for r in a:
        o = by_key.get(r["key"])
        if o is None:
            continue
        cell = lambda x, y: f"{x:.3f}/{y:.3f}"  # noqa: E731
        falls = f"{r.get('falls', int(r['fell']))}/{o['falls']}"
        w = " ".join(f"{cell(r['mae_whole'][i], o['mae_whole'][i]):>13}" for i in range(3))
        s = " ".join(f"{cell(r['mae_components'][i], o['mae_components'][i]):>13}" for i in range(3))
        print(f"{r['key']:<14} {falls:>5} {w} | {s}")


if __name__ == "__main__":
    main()
