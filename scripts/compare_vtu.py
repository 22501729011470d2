#!/usr/bin/env python3
"""Per-output-point radiosity of two `photometria solve` results of the same scene, compared at
every output point of the second (python3 standard library only).

    python3 scripts/compare_vtu.py REFERENCE.vtu OTHER.vtu [--array radiosity] [--json]

Typical use: the dense solve as the reference and `--method hierarchical` as the other. Their
output points differ (patch corners against leaf corners), so the reference's per-vertex values
are interpolated at each point of OTHER: linearly over the triangles of a fan of the reference
cell, of the same input face (cell array `face`), that contains the point. Prints how many
points were compared and the difference of the array (largest over the channels) relative to
the reference's mean value over its points and channels: RMS, 99th percentile and max.

Points favour the regions OTHER refined, so the same difference is also integrated over the
surface (`area_*` in --json): OTHER's per-vertex field, linear over the triangles of a fan of
each of its cells, is compared with the reference's at the three edge midpoints of each triangle
(weights of a third of its area each: the edge-midpoint rule, exact for quadratics on a
triangle; Strang & Fix, "An Analysis of the Finite Element Method", 1973, chapter 4). Relative to the reference's
area-weighted mean B̄ (what `--error` refers to, docs/theory.md "Hierarchical radiosity"): the
area-weighted RMS of the difference, and its area-weighted mean (the bias: how much light OTHER
gains or loses overall, the difference of the channels averaged).
"""

import argparse
import base64
import json
import math
import re
import struct
import sys
import zlib
from collections import defaultdict


def decode(payload, fmt):
    # photometria's .vtu: per array a base64 header (number of blocks, block size, last block
    # size, compressed sizes, UInt32 each) followed by the base64 of the zlib blocks.
    blocks = struct.unpack("<I", base64.b64decode(payload[:8])[:4])[0]
    header_chars = 4 * math.ceil(4 * (3 + blocks) / 3)
    header = struct.unpack(f"<{3 + blocks}I", base64.b64decode(payload[:header_chars]))
    data = base64.b64decode(payload[header_chars:])
    raw, at = bytearray(), 0
    for size in header[3:]:
        raw += zlib.decompress(data[at:at + size])
        at += size
    return struct.unpack(f"<{len(raw) // 8}{fmt}", bytes(raw))


def read_vtu(path):
    """{section: {name: (components, values)}} for PointData, CellData, Points and Cells."""
    text = open(path, encoding="utf-8").read()
    if 'compressor="vtkZLibDataCompressor"' not in text or 'header_type="UInt32"' not in text:
        sys.exit(f"{path}: expected a zlib-compressed .vtu with UInt32 headers (as photometria writes)")
    out = {}
    for section in ("PointData", "CellData", "Points", "Cells"):
        start = text.index(f"<{section}")
        block = text[start:text.index(f"</{section}>", start)]
        arrays = {}
        for m in re.finditer(r'<DataArray type="(Float64|Int64)" Name="([^"]+)"(?: NumberOfComponents="(\d+)")?'
                             r'[^>]*>\s*([^<]*)', block):
            arrays[m.group(2)] = (int(m.group(3) or 1), decode(m.group(4).strip(), "d" if m.group(1) == "Float64" else "q"))
        out[section] = arrays
    return out


def cells_of(vtu):
    offsets, connectivity = vtu["Cells"]["offsets"][1], vtu["Cells"]["connectivity"][1]
    begin = 0
    for end in offsets:
        yield connectivity[begin:end]
        begin = end


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


class Interpolator:
    """The reference's per-vertex array at any point of one of its input faces."""

    def __init__(self, vtu, array, cell_size):
        self.vtu = vtu
        self.points = vtu["Points"]["Points"][1]
        self.comps, self.values = vtu["PointData"][array]
        faces = vtu["CellData"]["face"][1]
        self.size = cell_size
        self.grid = defaultdict(list)  # (face, grid cell) -> triangles (a, b, c point indices)
        for face, cell in zip(faces, cells_of(vtu)):
            for k in range(1, len(cell) - 1):
                tri = (cell[0], cell[k], cell[k + 1])
                corners = [self.point(i) for i in tri]
                lo = [min(c[d] for c in corners) for d in range(3)]
                hi = [max(c[d] for c in corners) for d in range(3)]
                for gx in range(self.key(lo[0]), self.key(hi[0]) + 1):
                    for gy in range(self.key(lo[1]), self.key(hi[1]) + 1):
                        for gz in range(self.key(lo[2]), self.key(hi[2]) + 1):
                            self.grid[(face, gx, gy, gz)].append(tri)

    def mean(self):
        """The area-weighted mean of the array over the reference's surface (all channels)."""
        total_area, total = 0.0, 0.0
        for cell in cells_of(self.vtu):
            for k in range(1, len(cell) - 1):
                tri = (cell[0], cell[k], cell[k + 1])
                a, b, c = (self.point(i) for i in tri)
                n = cross(sub(b, a), sub(c, a))
                area = 0.5 * math.sqrt(dot(n, n))
                # A linear field's mean over a triangle is the mean of its corners.
                total += area * sum(self.values[self.comps * i + ch] for i in tri for ch in range(self.comps)) / (
                    3 * self.comps)
                total_area += area
        return total / total_area

    def key(self, x):
        return math.floor(x / self.size)

    def point(self, i):
        return self.points[3 * i:3 * i + 3]

    def at(self, face, p):
        best = None
        for tri in self.grid.get((face, self.key(p[0]), self.key(p[1]), self.key(p[2])), ()):
            a, b, c = (self.point(i) for i in tri)
            n = cross(sub(b, a), sub(c, a))
            area2 = dot(n, n)
            if area2 == 0.0:
                continue
            # Barycentric coordinates of p's projection on the triangle's plane.
            wa = dot(cross(sub(b, p), sub(c, p)), n) / area2
            wb = dot(cross(sub(c, p), sub(a, p)), n) / area2
            wc = 1.0 - wa - wb
            outside = -min(wa, wb, wc)
            if best is None or outside < best[0]:
                best = (outside, tri, (wa, wb, wc))
        if best is None or best[0] > 1e-6:
            return None
        _, tri, w = best
        return [sum(w[k] * self.values[self.comps * tri[k] + ch] for k in range(3)) for ch in range(self.comps)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("reference")
    ap.add_argument("other")
    ap.add_argument("--array", default="radiosity")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    ref, oth = read_vtu(args.reference), read_vtu(args.other)
    for name, vtu in ((args.reference, ref), (args.other, oth)):
        if args.array not in vtu["PointData"] or "face" not in vtu["CellData"]:
            sys.exit(f"{name}: no point array '{args.array}' or cell array 'face'")
    pts = ref["Points"]["Points"][1]
    extent = max(max(pts[d::3]) - min(pts[d::3]) for d in range(3))
    interpolate = Interpolator(ref, args.array, extent / 64)
    comps, values = ref["PointData"][args.array]
    scale = sum(values) / len(values)
    # Each point of OTHER belongs to one input face (a point is never shared across faces whose
    # values differ: sharp creases have a point per side).
    face_of = {}
    for face, cell in zip(oth["CellData"]["face"][1], cells_of(oth)):
        for i in cell:
            face_of.setdefault(i, face)
    opts, ovals = oth["Points"]["Points"][1], oth["PointData"][args.array][1]
    diffs, missed = [], 0
    for i, face in face_of.items():
        r = interpolate.at(face, opts[3 * i:3 * i + 3])
        if r is None:
            missed += 1
            continue
        diffs.append(max(abs(ovals[comps * i + ch] - r[ch]) for ch in range(comps)) / scale)
    if not diffs:
        sys.exit("no point of OTHER lies on a reference cell of its face")
    # Over the surface: OTHER's triangles, sampled at their edge midpoints.
    area_mean = interpolate.mean()
    weight, squares, bias, area_missed = 0.0, 0.0, 0.0, 0
    for face, cell in zip(oth["CellData"]["face"][1], cells_of(oth)):
        for k in range(1, len(cell) - 1):
            tri = (cell[0], cell[k], cell[k + 1])
            corners = [opts[3 * i:3 * i + 3] for i in tri]
            n = cross(sub(corners[1], corners[0]), sub(corners[2], corners[0]))
            third = math.sqrt(dot(n, n)) / 6.0
            for u, v in ((0, 1), (1, 2), (2, 0)):
                p = tuple(0.5 * (corners[u][d] + corners[v][d]) for d in range(3))
                r = interpolate.at(face, p)
                if r is None:
                    area_missed += 1
                    continue
                o = [0.5 * (ovals[comps * tri[u] + ch] + ovals[comps * tri[v] + ch]) for ch in range(comps)]
                squares += third * max((o[ch] - r[ch]) ** 2 for ch in range(comps))
                bias += third * sum(o[ch] - r[ch] for ch in range(comps)) / comps
                weight += third
    if weight == 0.0:
        sys.exit("no triangle of OTHER lies on a reference cell of its face")
    area_rms = math.sqrt(squares / weight) / area_mean
    area_bias = bias / weight / area_mean
    rms = math.sqrt(sum(d * d for d in diffs) / len(diffs))
    p99 = sorted(diffs)[int(0.99 * (len(diffs) - 1))]
    result = {"compared_points": len(diffs), "points_off_the_reference": missed, "rms_relative": rms,
              "p99_relative": p99, "max_relative": max(diffs), "reference_mean": scale,
              "area_rms_relative": area_rms, "area_bias_relative": area_bias, "reference_area_mean": area_mean,
              "area_samples_off_the_reference": area_missed}
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{len(diffs)} points compared ({missed} not on the reference's cells): {args.array} differs by "
              f"RMS {rms:.3g}, 99th percentile {p99:.3g}, max {max(diffs):.3g} of the reference's mean value {scale:.6g}")
        print(f"over the surface: RMS {area_rms:.3g}, bias {area_bias:+.3g} of the reference's area-weighted mean "
              f"{area_mean:.6g} ({area_missed} samples not on the reference's cells)")


if __name__ == "__main__":
    main()
