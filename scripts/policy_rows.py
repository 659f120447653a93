#!/usr/bin/env python3
"""One Markdown row per policy from `topa ablate --full` reports (ablation.json), for the lever write-ups in
docs/results/: t_fall standing and walking, command-noise success per level, ±60 N grid (when a `topa eval push
--range 60 --step 10 --json` output is given with --push60 POLICY=FILE), worst component MAE (whole window, mean over
the starts), w_z MAE on the two turns and the largest on a straight command, stand-stills on the turns, tracking
falls, gait at 0.5 m/s.
Usage: scripts/policy_rows.py [--push60 POLICY_JSON=PUSH_JSON ...] ABLATION_JSON ...
"""
import json
import sys


def mean_tfall(grid):
    t = grid["t_fall"]
    return sum(t) / len(t)


args = sys.argv[1:]
push60 = {}
while args and args[0] == "--push60":
    policy, path = args[1].split("=", 1)
    push60[policy] = mean_tfall(json.load(open(path)))
    args = args[2:]
if not args:
    sys.exit(__doc__)
print("| policy | t_fall standing (s) | t_fall walking (s) | noise success L1/L2/L3/L4 (%) | ±60 N grid (s) | "
      "worst component MAE | w_z MAE ccw / cw | largest w_z MAE on a straight command | stood still ccw / cw | "
      "tracking falls | gait at 0.5 m/s: steps/s, air (s), clearance (cm) |")
print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---|")
for path in args:
    for r in json.load(open(path))["results"]:
        trk = {t["key"]: t for t in r["tracking"]}
        worst = max((max(t["mae_whole"]), k) for k, t in trk.items())
        ccw, cw = trk["rotate_ccw"], trk["rotate_cw"]
        straight = max(t["mae_whole"][2] for k, t in trk.items() if not k.startswith("rotate"))
        starts = sum(t.get("starts", 1) for t in trk.values())
        falls = sum(t.get("falls", int(t["fell"])) for t in trk.values())
        g = trk["walk_forward"]["gait"]
        noise = " / ".join(f"{n['success_pct']:.0f}" for n in r["noise"])
        p60 = f"{push60[r['policy']]:.2f}" if r["policy"] in push60 else "–"
        print(f"| `{r['policy']}` | {mean_tfall(r['push']):.2f} | {mean_tfall(r['push_walking']):.2f} | {noise} | "
              f"{p60} | {worst[0]:.3f} ({worst[1]}) | {ccw['mae_whole'][2]:.3f} / {cw['mae_whole'][2]:.3f} | "
              f"{straight:.3f} | "
              f"{ccw.get('stood_still', 0)} / {cw.get('stood_still', 0)} | {falls}/{starts} | "
              f"{g['steps_per_s']:.2f}, {g['air_time_s']:.3f}, {100 * g['clearance_m']:.1f} |")
