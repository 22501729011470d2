#!/usr/bin/env bash
# Installs the Debian 12 packages Photometria builds with (we are root on CI and dev machines).
# Skips apt-get entirely when everything is already there.
set -euo pipefail
packages=(
  build-essential cmake pkg-config
  libeigen3-dev libopenmesh-dev libvtk9-dev libembree-dev
  libcli11-dev nlohmann-json3-dev libtinyobjloader-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libxsimd-dev libfmt-dev
  libopenmpi-dev openmpi-bin petsc-dev
  gnuplot-nox python3
  clang libclang-rt-14-dev libomp-14-dev clang-format
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
