#!/usr/bin/env bash
# Builds pbrt-v4 (CPU only, Release, -march=native) for bench/pbrt/side_by_side.py.
# pbrt-v4 is not part of tritrace: build it outside the repository and never commit it.
#
#   git clone --recursive https://github.com/mmp/pbrt-v4 /work/pbrt/src   # with its submodules
#   bench/pbrt/build_pbrt.sh /work/pbrt/src /work/pbrt/build [jobs]
#   bench/pbrt/side_by_side.py --pbrt /work/pbrt/build/pbrt
#
# Needs cmake, a C++17 compiler and the Debian packages libopenexr-dev zlib1g-dev libgl-dev
# libx11-dev libxrandr-dev libxinerama-dev libxcursor-dev libxi-dev (pbrt links its GLFW window
# code although --interactive is not used here). Without CUDA/OptiX pbrt builds for the CPU only.
#
# A source tree that is not a git checkout (an exported snapshot with the submodules' files put in
# src/ext/* by hand) fails pbrt's submodule commit check; the script then skips that check. If the
# snapshot lacks the two large generated tables src/pbrt/util/bluenoise.cpp and pmj02tables.cpp,
# it writes zero-filled stand-ins: they are read only by the "pmj02bn" sampler and by 8-bit PNG
# dithering, neither of which side_by_side.py uses (zsobol sampler, PFM output).
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: build_pbrt.sh PBRT_SOURCE_DIR BUILD_DIR [jobs]" >&2
  exit 2
fi
src=$(cd "$1" && pwd)
build=$2
jobs=${3:-2}
[[ -f $src/CMakeLists.txt && -d $src/src/pbrt ]] || {
  echo "build_pbrt.sh: $src: not a pbrt-v4 source tree" >&2
  exit 1
}
for d in ptex/src double-conversion/cmake filesystem/filesystem glfw/docs libdeflate/common \
  lodepng/examples qoi stb/tools utf8proc/bench openvdb/nanovdb; do
  [[ -e $src/src/ext/$d ]] || {
    echo "build_pbrt.sh: $src/src/ext/$d missing: clone with --recursive (git submodule update --init)" >&2
    exit 1
  }
done
if ! git -C "$src" rev-parse HEAD >/dev/null 2>&1 && ! grep -q 'local build: submodules' "$src/CMakeLists.txt"; then
  echo "build_pbrt.sh: $src is not a git checkout: skipping pbrt's submodule commit check"
  sed -i 's|^function (CHECK_EXT NAME DIR HASH)$|&\n  return ()  # local build: submodules extracted as plain folders|' "$src/CMakeLists.txt"
fi
util=$src/src/pbrt/util
if [[ ! -s $util/bluenoise.cpp ]]; then
  echo "build_pbrt.sh: writing a zero-filled stand-in for $util/bluenoise.cpp"
  cat >"$util/bluenoise.cpp" <<'EOF'
// Zero-filled stand-in (bench/pbrt/build_pbrt.sh): read only by the pmj02bn sampler and PNG dithering.
#include <pbrt/util/bluenoise.h>
namespace pbrt {
PBRT_CONST uint16_t
    BlueNoiseTextures[NumBlueNoiseTextures][BlueNoiseResolution][BlueNoiseResolution] = {};
}
EOF
fi
if [[ ! -s $util/pmj02tables.cpp ]]; then
  echo "build_pbrt.sh: writing a zero-filled stand-in for $util/pmj02tables.cpp"
  cat >"$util/pmj02tables.cpp" <<'EOF'
// Zero-filled stand-in (bench/pbrt/build_pbrt.sh): read only by the pmj02bn sampler.
#include <pbrt/util/pmj02tables.h>
namespace pbrt {
PBRT_CONST uint32_t pmj02bnSamples[nPMJ02bnSets][nPMJ02bnSamples][2] = {};
}
EOF
fi
# PBRT_BUILD_NATIVE_EXECUTABLE (on by default) adds -march=native; BUILD_TESTING off keeps the
# submodules' own tests out.
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release -DPBRT_BUILD_NATIVE_EXECUTABLE=ON \
  -DBUILD_TESTING=OFF
cmake --build "$build" -j"$jobs" --target pbrt_exe
echo "build_pbrt.sh: built $build/pbrt"
