#!/usr/bin/env bash
# Sourced from the repository root by seeds.sh and sweep.sh: the bundle travels packed (bundle.sh), so it is
# unpacked on first use.
if [ ! -x .device/bundle/run ] && [ -f .device/bundle.txz ]; then
  python3 -c "import tarfile; tarfile.open('.device/bundle.txz').extractall('.device')"
fi
