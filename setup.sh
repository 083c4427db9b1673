#!/usr/bin/env bash
# Installs ffdsim's Debian packages when missing, then configures and builds into build/.
# Usage: ./setup.sh [extra cmake -D options]      (FFDSIM_BUILD_DIR overrides build/)
set -euo pipefail
cd "$(dirname "$0")"
packages=(build-essential cmake ninja-build pkg-config libeigen3-dev libtomlplusplus-dev libassimp-dev
          libcli11-dev nlohmann-json3-dev catch2 libbenchmark-dev libconcurrentqueue-dev
          libreaderwriterqueue-dev
          # content hashes of the files a recording names
          libxxhash-dev
          # SIMD kernels: Highway (run-time dispatch over the x86 targets)
          libhwy-dev
          # letter meshes: glyph outlines through FreeType (below), their caps triangulated by
          # the GLU tessellator
          libglu1-mesa-dev
          # the viewer: OpenGL through libepoxy, a GLFW window or EGL headless (Mesa: llvmpipe
          # without a GPU), Dear ImGui with FreeType and the DejaVu font, PNGs through stb,
          # and Xvfb + xauth for the window test
          libimgui-dev libepoxy-dev libglfw3-dev libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri
          libfreetype-dev fonts-dejavu-core libstb-dev xvfb xauth
          # FCL: the broad-phase race in ffdsim bench; gnuplot: the plot of ffdsim accuracy
          libfcl-dev gnuplot-nox
          # CGAL: exact triangle-triangle tests for the surface-intersection measure
          libcgal-dev
          # the Python reference bridge of the device link (ui/device/bridges), run by the tests
          python3
          # ffdsim sweep's engines: GNU parallel (cores or ssh hosts) and Slurm (job arrays); the
          # tests run a sweep through each, Slurm as a one-node cluster of their own
          parallel slurm-wlm munge
          # the Python module (ui/python): pybind11 for Debian's Python, NumPy; pytest runs its
          # tests and matplotlib draws the examples' plots
          pybind11-dev python3-dev python3-numpy python3-pytest python3-matplotlib)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
build_dir=${FFDSIM_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$build_dir" -j2
