#!/usr/bin/env bash
# Installs the Debian 12 packages tritrace needs to build, test and benchmark.
# Idempotent: packages already installed are skipped; apt-get runs only when something is missing.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libglm-dev libtbb-dev libcli11-dev libstb-dev libembree-dev nlohmann-json3-dev
  libassimp-dev assimp-testmodels
  # The assimp command: its pbrt exporter writes the pbrt-v4 files the loader is tested against.
  assimp-utils
  # The native OBJ/MTL reader (scene/io/obj_reader.h); without it OBJ goes through assimp.
  libtinyobjloader-dev
  # OpenEXR 3.1 for .exr output (float or half RGB with AOV layers).
  libopenexr-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  # tritrace-view: SDL2, SDL2_ttf and the overlay's font; its tests run it in Xvfb and press keys
  # with xdotool; libx11-dev for the viewer's X error handler and for the test that closes its
  # window as a window manager does.
  libsdl2-dev libsdl2-ttf-dev fonts-dejavu-core xvfb xdotool libx11-dev
  clang-format clang-tidy
  # The Python module (import tritrace): Debian's Python headers, pybind11 and NumPy; pytest runs
  # its tests.
  python3-dev pybind11-dev python3-numpy python3-pytest
  # Distributed rendering (docs/DISTRIBUTED.md): Open MPI for the optional --mpi mode
  # (TRITRACE_WITH_MPI), and a single-node Slurm with munge for the job-array test.
  libopenmpi-dev openmpi-bin slurmctld slurmd slurm-client munge
  # The sanitizer runtimes for make test-asan / test-tsan (g++ pulls them in; named for clarity),
  # and clang 14 with its own, which compiles the ASan + UBSan and TSan builds (Makefile:
  # SANITIZE_COMPILERS).
  libasan8 libubsan1 libtsan2 clang-14 libclang-rt-14-dev
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
