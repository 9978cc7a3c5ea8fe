#!/usr/bin/env bash
# Installs every Debian package graspsim needs. Idempotent: when everything is
# already installed it only runs dpkg queries (well under a second).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkgconf ccache git
  libeigen3-dev libyaml-cpp-dev libassimp-dev libcli11-dev
  liblcm-dev liblcm-bin libglib2.0-dev
  libosmesa6-dev libstb-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libfclib-dev libhdf5-dev
  clang libclang-rt-14-dev
  ffmpeg gnuplot-nox
  libcpp-httplib-dev chromium
)
# the live view's page takes three.js from npm at build time (view/CMakeLists.txt); Debian's
# npm only where no npm is on PATH (a Node.js from elsewhere brings its own)
if ! command -v npm >/dev/null 2>&1; then packages+=(npm); fi
# optional extras: the Siconos side-by-side benchmark and the mesh import test models
if [ "${GRASPSIM_SETUP_MINIMAL:-0}" != 1 ]; then
  packages+=(libsiconos-numerics-dev)
  # the mesh import test walks every model of assimp's own test suite
  packages+=(assimp-testmodels)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "setup: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
