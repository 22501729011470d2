#!/usr/bin/env python3
"""scripts/compare_vtu.py on fields whose differences are known in closed form.

Two .vtu files of the unit square (one quad, or 2 x 2 quads of unequal sizes for the other), in
the zlib-compressed layout photometria writes, with a linear per-vertex array `radiosity`:
- a field against itself differs by nothing;
- f = x against f = x + 0.1: the area-weighted mean of the reference is 1/2, so RMS and bias
  over the surface are both 0.1 / 0.5 = 0.2;
- f = x against f = 1 - x: the difference 1 - 2x has mean 0 and mean square 1/3 over the
  square, so the surface RMS is sqrt(1/3) / 0.5 and the bias 0 (the edge-midpoint rule is exact
  for this quadratic).
Run: python3 tests/test_compare_vtu.py (CTest runs it).
"""

import base64
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scripts", "compare_vtu.py")


def encoded(values, fmt):
    raw = struct.pack(f"<{len(values)}{fmt}", *values)
    block = zlib.compress(raw)
    header = struct.pack("<4I", 1, len(raw), len(raw), len(block))
    return base64.b64encode(header).decode() + base64.b64encode(block).decode()


def array(kind, name, values, components=1):
    fmt = "d" if kind == "Float64" else "q"
    return (f'<DataArray type="{kind}" Name="{name}" NumberOfComponents="{components}" format="binary">\n'
            f'{encoded(values, fmt)}\n</DataArray>\n')


def write_square(path, xs, ys, field):
    """The unit square in z = 0 cut at xs and ys into quads of input face 0, `field(x, y)` at each vertex."""
    points, cells, offsets = [], [], []
    for y in ys:
        for x in xs:
            points += [x, y, 0.0]
    columns = len(xs)
    for j in range(len(ys) - 1):
        for i in range(columns - 1):
            a = j * columns + i
            cells += [a, a + 1, a + columns + 1, a + columns]
            offsets.append(len(cells))
    values = [field(points[3 * k], points[3 * k + 1]) for k in range(len(points) // 3)]
    with open(path, "w", encoding="utf-8") as out:
        out.write('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian" '
                  'header_type="UInt32" compressor="vtkZLibDataCompressor">\n<UnstructuredGrid>\n'
                  f'<Piece NumberOfPoints="{len(points) // 3}" NumberOfCells="{len(offsets)}">\n')
        out.write("<PointData>\n" + array("Float64", "radiosity", values) + "</PointData>\n")
        out.write("<CellData>\n" + array("Int64", "face", [0] * len(offsets)) + "</CellData>\n")
        out.write("<Points>\n" + array("Float64", "Points", points, 3) + "</Points>\n")
        out.write("<Cells>\n" + array("Int64", "connectivity", cells) + array("Int64", "offsets", offsets) +
                  "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n")


def compare(reference, other):
    done = subprocess.run([sys.executable, SCRIPT, reference, other, "--json"], capture_output=True, text=True,
                          check=True)
    return json.loads(done.stdout)


def expect_near(what, got, want, tolerance=1e-12):
    if abs(got - want) > tolerance:
        sys.exit(f"FAIL {what}: {got!r}, expected {want!r} (within {tolerance})")
    print(f"ok {what}: {got:.15g}")


def main():
    with tempfile.TemporaryDirectory() as scratch:
        reference, shifted, mirrored = (os.path.join(scratch, n) for n in ("ref.vtu", "shifted.vtu", "mirror.vtu"))
        # The others' cells differ in area (the surface integral must weigh them by it).
        write_square(reference, [0.0, 1.0], [0.0, 1.0], lambda x, y: x)
        write_square(shifted, [0.0, 0.5, 1.0], [0.0, 0.5, 1.0], lambda x, y: x + 0.1)
        write_square(mirrored, [0.0, 0.25, 1.0], [0.0, 0.7, 1.0], lambda x, y: 1.0 - x)

        same = compare(reference, reference)
        for key in ("rms_relative", "max_relative", "area_rms_relative", "area_bias_relative"):
            expect_near(f"itself, {key}", same[key], 0.0)
        expect_near("itself, reference_area_mean", same["reference_area_mean"], 0.5)

        up = compare(reference, shifted)
        expect_near("x + 0.1, area_rms_relative", up["area_rms_relative"], 0.2)
        expect_near("x + 0.1, area_bias_relative", up["area_bias_relative"], 0.2)
        expect_near("x + 0.1, compared_points", up["compared_points"], 9)

        flipped = compare(reference, mirrored)
        expect_near("1 - x, area_rms_relative", flipped["area_rms_relative"], (1.0 / 3.0) ** 0.5 / 0.5)
        expect_near("1 - x, area_bias_relative", flipped["area_bias_relative"], 0.0)
        expect_near("1 - x, area_samples_off_the_reference", flipped["area_samples_off_the_reference"], 0)


if __name__ == "__main__":
    main()
