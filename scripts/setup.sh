#!/usr/bin/env bash
# Installs what a fresh Debian bookworm machine lacks for TopA: MuJoCo 2.2.2 (libmujoco-dev) and its samples
# (mujoco-testspeed, used by `topa bench physics`), protoc, and headless OpenGL for MuJoCo's renderer (EGL with
# Mesa's software rasteriser: `--video`). Sourced by run.sh and test.sh; safe to run again. MP4 output also needs
# ffmpeg (`apt-get install ffmpeg`); GIF needs nothing more.
set -euo pipefail

need_pkgs=()
[ -e /usr/include/mujoco/mujoco.h ] && ldconfig -p 2>/dev/null | grep -q 'libmujoco.so.2.2' || need_pkgs+=(libmujoco-dev)
command -v mujoco-testspeed >/dev/null 2>&1 || need_pkgs+=(libmujoco-samples)
# python3: scripts/train_seeds.sh and scripts/ship_policy.py read run folders' JSON with it.
command -v python3 >/dev/null 2>&1 || need_pkgs+=(python3)
# python3-venv: the second evaluator's environment (scripts/mujoco_release/install.sh).
python3 -c 'import ensurepip' >/dev/null 2>&1 || need_pkgs+=(python3-venv)
# protoc: the TensorBoard event writer (crate tboard) compiles its protobuf schema at build time.
command -v protoc >/dev/null 2>&1 || need_pkgs+=(protobuf-compiler)
# The operator's gamepad (gilrs): libudev, found through pkg-config.
command -v pkg-config >/dev/null 2>&1 || need_pkgs+=(pkg-config)
pkg-config --exists libudev 2>/dev/null || need_pkgs+=(libudev-dev)
# Headless rendering: libEGL (glvnd), Mesa's EGL vendor library and its software (llvmpipe) driver.
ldconfig -p 2>/dev/null | grep -q 'libEGL.so.1 ' || need_pkgs+=(libegl1)
ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa.so.0 ' || need_pkgs+=(libegl-mesa0)
[ -e /usr/lib/x86_64-linux-gnu/dri/swrast_dri.so ] || [ -e /usr/lib/aarch64-linux-gnu/dri/swrast_dri.so ] ||
  need_pkgs+=(libgl1-mesa-dri)
# The viewer (`topa view`): GLFW 3.4 is built from the glfw crate's sources (Debian ships 3.3): cmake and the X11
# headers; the window's OpenGL is Mesa's GLX (libgl1). Xvfb: its test draws into a virtual display.
command -v cmake >/dev/null 2>&1 || need_pkgs+=(cmake)
for p in x11 xrandr xinerama xcursor xi xext; do
  pkg-config --exists "$p" 2>/dev/null || need_pkgs+=("lib$p-dev")
done
ldconfig -p 2>/dev/null | grep -q 'libGL.so.1 ' || need_pkgs+=(libgl1)
command -v Xvfb >/dev/null 2>&1 || need_pkgs+=(xvfb)
# Multi-machine training (TOPA_MPI=1, the `mpi` cargo feature): Open MPI, and libclang for the binding's bindgen.
if [ "${TOPA_MPI:-0}" = 1 ]; then
  command -v mpirun >/dev/null 2>&1 || need_pkgs+=(openmpi-bin)
  [ -e /usr/lib/x86_64-linux-gnu/openmpi/include/mpi.h ] || [ -e /usr/include/x86_64-linux-gnu/mpi/mpi.h ] ||
    [ -e /usr/lib/aarch64-linux-gnu/openmpi/include/mpi.h ] || need_pkgs+=(libopenmpi-dev)
  # libclang itself (libclang-cpp, which other packages bring, is not what bindgen loads).
  ldconfig -p 2>/dev/null | grep -qE 'libclang(-[0-9.]+)?\.so' || need_pkgs+=(libclang-dev)
fi
if [ ${#need_pkgs[@]} -gt 0 ]; then
  echo "setup: installing ${need_pkgs[*]} (apt-get)" >&2
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need_pkgs[@]}" >/dev/null
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found: install the Rust toolchain (https://rustup.rs), then run this again" >&2
  exit 1
fi
