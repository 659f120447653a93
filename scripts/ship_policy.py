#!/usr/bin/env python3
"""Copies a training run's exported policy into assets/policies/NAME.{safetensors,json}.

The JSON sidecar keeps the run's provenance (command, config, seed, iterations, samples, wall time); only the
name of the weights file changes, and the weights' CRC is checked so nothing is shipped that the loader rejects.
Run folders may live anywhere (e.g. under the home folder): the recorded command names them as runs/<folder>,
so no machine's paths end up in the repository. NAME may name a subfolder (C/seed1 for a group's seed).
Usage: scripts/ship_policy.py ~/runs/C-s1 C/seed1
"""
import json
import shutil
import sys
import zlib
from pathlib import Path


REPO = Path(__file__).resolve().parent.parent


def portable(t):
    """A file of the repository (a preset given by its absolute path) by its path in the repository; any other
    absolute path (e.g. --init-from a run kept elsewhere) as runs/<its name>."""
    if not Path(t).is_absolute():
        return t
    try:
        return str(Path(t).resolve().relative_to(REPO))
    except ValueError:
        return f"runs/{Path(t).name}"


def strings(v):
    """Every string in the sidecar, however deeply nested."""
    if isinstance(v, str):
        yield v
    elif isinstance(v, dict):
        for x in v.values():
            yield from strings(x)
    elif isinstance(v, list):
        for x in v:
            yield from strings(x)


if len(sys.argv) != 3 or sys.argv[1].startswith("-"):
    sys.exit("usage: scripts/ship_policy.py RUN_FOLDER NAME   (e.g. ~/runs/C-s1 C/seed1)")
run, name = Path(sys.argv[1]), sys.argv[2]
if not (run / "policy.json").is_file():
    sys.exit(f"{run}/policy.json not found: is {run} a finished training run (topa train --out {run})?")
meta = json.loads((run / "policy.json").read_text())
weights = (run / meta["weights"]).read_bytes()
if zlib.crc32(weights) != meta["weights_crc32"]:
    sys.exit(f"{run}/{meta['weights']} does not match its sidecar's CRC: re-export the run")
root = REPO / "assets" / "policies"
dest = (root / name).parent
stem = Path(name).name
# Where the runs lived on the training machine is nobody's business: runs/<folder> in the record.
runs_dir = str(run.resolve().parent)
p = meta["provenance"]
p["command"] = p["command"].replace(runs_dir + "/", "runs/")
p["command"] = " ".join(portable(t) for t in p["command"].split(" "))

# A shipped sidecar names files relative to the repository; any absolute path left is this machine's.
if any(Path(t).is_absolute() for s in strings(meta) for t in s.replace("=", " ").split()):
    sys.exit(f"{run}/policy.json still names a path of this machine after rewriting the command: ship by hand")
# Only now that the sidecar is clean is anything written.
dest.mkdir(parents=True, exist_ok=True)
shutil.copyfile(run / meta["weights"], dest / f"{stem}.safetensors")
meta["weights"] = f"{stem}.safetensors"
tmp = dest / f".{stem}.json.tmp"
tmp.write_text(json.dumps(meta, indent=2) + "\n")
tmp.replace(dest / f"{stem}.json")
p = meta["provenance"]
print(f"{name}: {p['iterations']} iterations, {p['samples']} samples, {p['wall_time_s'] / 3600:.2f} h, "
      f"seed {p['seed']}, trained on {p['trained_on']}\n  {p['command']}")
