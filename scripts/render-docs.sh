#!/usr/bin/env bash
# Regenerates the pictures in docs/images/ (docs/pictures.md): solves the shipped scenes into a
# temporary folder and renders them in true colour with scripts/render.py.
#   docs/images/cornell_box.png          the Cornell box, smooth (per-vertex radiosity)
#   docs/images/cornell_box_patches.png  the same result, one flat colour per patch
#   docs/images/room_with_table.png      room_with_table seen through its near wall
#   docs/images/crease-angle.png         a bumpy sphere in the Cornell box solved with
#                                        --crease-angle 0 and with the default, side by side;
#                                        only when `$PHOTOMETRIA solve --help` has --crease-angle
# Usage: scripts/render-docs.sh
# Environment: PHOTOMETRIA (default build/photometria), PVPYTHON (default pvpython). Without an X
# display the renders run under `xvfb-run -a` (pvpython builds that render off-screen without X
# need no display; set RENDER_WRAPPER= to run them bare).
set -euo pipefail
cd "$(dirname "$0")/.."

photometria=${PHOTOMETRIA:-build/photometria}
pvpython=${PVPYTHON:-pvpython}
if [[ ! -x $photometria ]]; then
    echo "render-docs.sh: $photometria is not an executable (build it, or set PHOTOMETRIA)" >&2
    exit 1
fi
if ! command -v "$pvpython" >/dev/null; then
    echo "render-docs.sh: no $pvpython (ParaView's Python; see docs/pictures.md, or set PVPYTHON)" >&2
    exit 1
fi
if [[ -z ${RENDER_WRAPPER+set} ]]; then
    if [[ -z ${DISPLAY:-} ]] && command -v xvfb-run >/dev/null; then
        RENDER_WRAPPER="xvfb-run -a"
    else
        RENDER_WRAPPER=""
    fi
fi
render() { $RENDER_WRAPPER "$pvpython" scripts/render.py "$@"; }

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p docs/images

echo "== Cornell box"
"$photometria" solve meshes/cornell_box.obj -o "$work/cornell_box.vtu" --quiet
render "$work/cornell_box.vtu" --output docs/images/cornell_box.png
render "$work/cornell_box.vtu" --cell-data --output docs/images/cornell_box_patches.png

echo "== room_with_table"
"$photometria" solve meshes/room_with_table.obj -o "$work/room_with_table.vtu" --quiet
# From outside the z = 3 m wall (culled: it faces inward), a little above eye height.
render "$work/room_with_table.vtu" --output docs/images/room_with_table.png \
    --camera-position 2,1.9,7.4 --focal-point 2,1.05,1.5

echo "== crease angle"
help=$("$photometria" solve --help)
if ! grep -q -- '--crease-angle' <<<"$help"; then
    echo "render-docs.sh: $photometria solve has no --crease-angle option: docs/images/crease-angle.png not made" >&2
    exit 0
fi
# The default angle, for the label, from the help line (e.g. "... (default 30)").
default_angle=$(awk '/--crease-angle/ {on = 1; print; next} on && /^ *-/ {exit} on {print}' <<<"$help" \
    | grep -o -i 'default[^0-9]*[0-9.]\+' | head -n1 | grep -o '[0-9.]\+$' || true)
default_label="default crease angle"
[[ -n $default_angle ]] && default_label="crease angle ${default_angle}°"

python3 meshes/make_meshes.py --scanned-object "$work/scanned.obj" >/dev/null
cp meshes/cornell_box.mtl "$work/"
echo "solving the scanned object twice (about 3 min and 1.5 min on 2 cores)"
"$photometria" solve "$work/scanned.obj" -o "$work/faceted.vtu" --crease-angle 0 --quiet
"$photometria" solve "$work/scanned.obj" -o "$work/smooth.vtu" --quiet
render "$work/faceted.vtu" "$work/smooth.vtu" --output docs/images/crease-angle.png --size 600x450 \
    --camera-position=-0.2,0.8,1.9 --focal-point=-0.42,0.27,0.5 --view-angle 34 \
    --label "crease angle 0°" --label "$default_label"
