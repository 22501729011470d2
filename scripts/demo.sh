#!/usr/bin/env bash
# The main job on the shipped default scene: install, build, solve the Cornell box to cornell.vtu.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
build/photometria solve meshes/cornell_box.obj -o cornell.vtu
echo "Open cornell.vtu in ParaView (point data: radiosity, irradiance)."
