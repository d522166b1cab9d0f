#!/usr/bin/env bash
# Installs every Debian package Penumbra's build, tests and benchmarks need.
# Idempotent: does nothing (and needs no network) when everything is present.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config clang-format
  # core libraries
  libtbb-dev libglm-dev libeigen3-dev libfmt-dev libspdlog-dev libcli11-dev nlohmann-json3-dev libpcg-cpp-dev
  # the photon map's kd-tree
  libnanoflann-dev
  # file formats
  libtinyobjloader-dev libtinygltf-dev libstb-dev libopenexr-dev libwebp-dev
  # OpenGL 4.5 through EGL (Mesa llvmpipe where there is no GPU) and the viewer
  libepoxy-dev libegl-dev libgl-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libimgui-dev
  # the viewer's tests: a virtual X display with Mesa's GLX
  xvfb
  # tests, benchmarks, and the ray-intersection peer
  libgtest-dev libgmock-dev libbenchmark-dev libembree-dev
  # plots of benchmark results for the docs (make plots)
  python3-matplotlib
  # the Python module (import penumbra) and its tests
  python3-dev pybind11-dev python3-numpy python3-pytest
  # runs over several processes (mpirun) and their tests
  libopenmpi-dev openmpi-bin
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

echo "install-deps: installing ${missing[*]}"
sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
