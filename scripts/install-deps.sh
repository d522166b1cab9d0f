#!/usr/bin/env bash
# Installs every Debian package Penumbra's build, tests and benchmarks need, and the web viewer's
# npm packages (web/package-lock.json) into web/node_modules.
# Idempotent: does nothing (and needs no network) when everything is present.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config clang-format
  # core libraries
  libtbb-dev libglm-dev libeigen3-dev libfmt-dev libspdlog-dev libcli11-dev nlohmann-json3-dev libpcg-cpp-dev
  # the photon map's kd-tree
  libnanoflann-dev
  # file formats
  libtinyobjloader-dev libstb-dev libopenexr-dev libwebp-dev
  # texture images: PNG (libpng, with zlib) and JPEG (libjpeg-turbo)
  libpng-dev zlib1g-dev libjpeg-dev
  # compressed glTF: Draco (KHR_draco_mesh_compression) and meshopt (EXT_/KHR_meshopt_compression)
  libdraco-dev libmeshoptimizer-dev
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
  # pip install . offline into a virtual environment (pyproject.toml, setup.py), progress bars,
  # and the example notebook's run (examples/penumbra.ipynb)
  python3-venv python3-pip python3-setuptools python3-wheel python3-tqdm python3-nbconvert
  python3-ipykernel
  # runs over several processes (mpirun) and their tests
  libopenmpi-dev openmpi-bin
  # the web viewer's browser test (docs/web-viewer.md): headless chromium, driven by
  # puppeteer-core from npm, which downloads no browser of its own
  chromium
)
# node and npm for the web viewer (three.js, puppeteer-core, the glTF validator), unless the
# machine has them already from elsewhere
if ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${missing[*]}"
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -qq
  "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The web viewer's npm packages, exactly as web/package-lock.json pins them, whenever
# web/node_modules is missing or older than the lock file (npm ci rewrites
# node_modules/.package-lock.json, so a finished install is newer).
web="$root/web"
if [ ! -f "$web/node_modules/.package-lock.json" ] ||
   [ "$web/package-lock.json" -nt "$web/node_modules/.package-lock.json" ]; then
  echo "install-deps: npm ci in web/"
  (cd "$web" && PUPPETEER_SKIP_DOWNLOAD=1 npm ci --no-audit --no-fund --loglevel=error)
fi
