#!/usr/bin/env bash
# Packs the release `topa` and every shared library it loads (libmujoco and its dependencies, glibc and the loader
# included) into .device/bundle, so that the binary runs on a machine without Rust, MuJoCo or Debian's glibc
# (the lent 16-core machine). Run it from the repository root after `cargo build --release`; on that machine
# start the binary through the carried loader: `.device/bundle/run topa …`. The repository's own files and the bundle
# together pass the 64 MiB that a call may carry, so it is also packed as .device/bundle.txz (about a quarter of its
# size): carry that file alone; seeds.sh and sweep.sh unpack it there.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${CARGO_TARGET_DIR:-target}/release/topa"
[ -x "$bin" ] || { echo "bundle: $bin not found: run cargo build --release first" >&2; exit 1; }
out=.device/bundle
rm -rf "$out" && mkdir -p "$out/lib"
# Debug info stays here: the carried tree is size-limited.
strip -o "$out/topa" "$bin"
ldd "$bin" | awk '/=> \//{print $3} /^[ \t]*\/lib/{print $1}' | sort -u | while read -r lib; do
  cp -L "$lib" "$out/lib/"
done
cat > "$out/run" <<'SH'
#!/usr/bin/env bash
# Runs a bundled program through the bundled loader and libraries (independent of the host's glibc).
here="$(cd "$(dirname "$0")" && pwd)"
prog="$1"; shift
exec "$here/lib/ld-linux-x86-64.so.2" --library-path "$here/lib" "$here/$prog" "$@"
SH
chmod +x "$out/run"
tar -C .device -cJf .device/bundle.txz bundle
du -sh "$out" .device/bundle.txz
