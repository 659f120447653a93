#!/usr/bin/env python3
"""Copies a training run's exported policy into assets/policies/NAME.{safetensors,json}.

The JSON sidecar keeps the run's provenance (command, config, seed, iterations, samples, wall time); only the
name of the weights file changes, and the weights' CRC is checked so nothing is shipped that the loader rejects.
Usage: scripts/ship_policy.py runs/C C
"""
import json
import shutil
import sys
import zlib
from pathlib import Path

run, name = Path(sys.argv[1]), sys.argv[2]
meta = json.loads((run / "policy.json").read_text())
weights = (run / meta["weights"]).read_bytes()
if zlib.crc32(weights) != meta["weights_crc32"]:
    sys.exit(f"{run}/{meta['weights']} does not match its sidecar's CRC: re-export the run")
dest = Path(__file__).resolve().parent.parent / "assets" / "policies"
dest.mkdir(parents=True, exist_ok=True)
shutil.copyfile(run / meta["weights"], dest / f"{name}.safetensors")
meta["weights"] = f"{name}.safetensors"
tmp = dest / f".{name}.json.tmp"
tmp.write_text(json.dumps(meta, indent=2) + "\n")
tmp.replace(dest / f"{name}.json")
p = meta["provenance"]
print(f"{name}: {p['iterations']} iterations, {p['samples']} samples, {p['wall_time_s'] / 3600:.2f} h, "
      f"seed {p['seed']}, trained on {p['trained_on']}\n  {p['command']}")
