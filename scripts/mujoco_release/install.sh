#!/usr/bin/env bash
# Creates .venv-mujoco-release in the repository root with the current MuJoCo release's official Python bindings
# and ONNX Runtime, for scripts/mujoco_release/eval_tracking.py (a second evaluator, independent of the Rust stack
# and of MuJoCo 2.2). Idempotent: an existing venv with the pinned versions is left as it is.
#
#   bash scripts/mujoco_release/install.sh          # then:
#   .venv-mujoco-release/bin/python scripts/mujoco_release/eval_tracking.py --help
#
# Python >= 3.10 (tomllib from 3.11; tomli is installed on 3.10). numpy 2.4.x is the last series for Python 3.11.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
VENV="$ROOT/.venv-mujoco-release"
PYTHON="${PYTHON:-python3}"

PINS=(
  "mujoco==4.0.0"
  "onnxruntime==1.31.1"
  "numpy==2.4.6"
)

if ! "$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 10) else 1)'; then
  echo "install.sh: needs Python >= 3.10 (found $("$PYTHON" --version 2>&1)); set PYTHON=..." >&2
  exit 1
fi
if ! "$PYTHON" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)'; then
  PINS+=("tomli==2.2.1")
fi

if [ ! -x "$VENV/bin/python" ]; then
  "$PYTHON" -m venv "$VENV"
fi

# Already installed at the pinned versions: nothing to do.
if "$VENV/bin/python" - "${PINS[@]}" <<'EOF'
import sys
from importlib.metadata import version, PackageNotFoundError
for pin in sys.argv[1:]:
    name, want = pin.split("==")
    try:
        if version(name) != want:
            sys.exit(1)
    except PackageNotFoundError:
        sys.exit(1)
EOF
then
  echo "install.sh: $VENV already has ${PINS[*]}"
  exit 0
fi

"$VENV/bin/python" -m pip install --quiet --upgrade pip
"$VENV/bin/python" -m pip install --quiet "${PINS[@]}"
"$VENV/bin/python" -c 'import mujoco, onnxruntime, numpy; print("install.sh: mujoco", mujoco.__version__, "| onnxruntime", onnxruntime.__version__, "| numpy", numpy.__version__)'
