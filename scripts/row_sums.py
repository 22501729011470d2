#!/usr/bin/env python3
"""Row sums of a face-level view-factor matrix of a closed room, against their exact value 1
(python3 standard library only).

    python3 scripts/row_sums.py ROOM.vs3 FACES.csv [--view3d] [--json]

ROOM.vs3 from `meshes/make_meshes.py --many-faces H ROOM.vs3`; FACES.csv from `photometria
viewfactors ROOM.vs3 --by face -o FACES.csv`, or with --view3d View3D 4.0's text output of the same
file (`view3d ROOM.vs3 OUT.txt`).

In a closed room the exact visible factors from any point partition its hemisphere, so every row
sums to 1, except for faces that see something other than the front of a face. Those are left out:
 - covered faces: a coplanar face of opposite orientation overlaps them (a floor quad under a table
   leg, the table's underside at a leg's top);
 - faces that see the back of an open surface (one with an edge no other face shares, such as the
   ceiling light): every face with a corner strictly behind such a face's plane.
Prints how many rows are checked and the worst, 99th-percentile and median |sum - 1|.
"""

import argparse
import json
import math
from collections import Counter

from vs3 import read_vs3  # scripts/vs3.py


def sub(a, b):
    return tuple(a[i] - b[i] for i in range(3))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def normal(f):
    n = (0.0, 0.0, 0.0)
    for k in range(len(f)):  # Newell
        n = tuple(n[i] + c for i, c in enumerate(cross(f[k], f[(k + 1) % len(f)])))
    length = math.sqrt(dot(n, n))
    return tuple(x / length for x in n)


def excluded_faces(faces, tol=1e-9):
    normals = [normal(f) for f in faces]
    key = lambda p: tuple(round(x, 9) for x in p)
    edges = Counter()
    for f in faces:
        for k in range(len(f)):
            edges[frozenset((key(f[k]), key(f[(k + 1) % len(f)])))] += 1
    open_faces = [b for b, f in enumerate(faces)
                  if any(edges[frozenset((key(f[k]), key(f[(k + 1) % len(f)])))] < 2 for k in range(len(f)))]
    out = set()
    for a, f in enumerate(faces):
        for b in open_faces:
            if b != a and any(dot(normals[b], sub(p, faces[b][0])) < -tol for p in f):
                out.add(a)
                break
    # Covered: axis-aligned faces only (the generator's), by overlap of their boxes in the plane.
    for a, fa in enumerate(faces):
        ax = max(range(3), key=lambda k: abs(normals[a][k]))
        others = [k for k in range(3) if k != ax]
        for b, fb in enumerate(faces):
            if b == a or normals[a][ax] * normals[b][ax] >= 0 or abs(fa[0][ax] - fb[0][ax]) > tol:
                continue
            lo = [max(min(p[k] for p in fa), min(p[k] for p in fb)) for k in others]
            hi = [min(max(p[k] for p in fa), max(p[k] for p in fb)) for k in others]
            if all(hi[m] - lo[m] > tol for m in range(2)):
                out.add(a)
    return out


def row_sums(path, view3d):
    sums = []
    with open(path) as fh:
        if view3d:  # a header line, the areas, one line per row, then the emissivities
            next(fh), next(fh)
            for line in fh:
                sums.append(sum(float(v) for v in line.split()))
            sums = sums[:-1]
        else:
            next(fh)
            for line in fh:
                sums.append(sum(float(v) for v in line.rstrip("\n").split(",")[2:]))
    return sums


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("room")
    parser.add_argument("matrix")
    parser.add_argument("--view3d", action="store_true", help="MATRIX is View3D's text output")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    faces = read_vs3(args.room)
    skip = excluded_faces(faces)
    sums = row_sums(args.matrix, args.view3d)
    if len(sums) != len(faces):
        raise SystemExit(f"{args.matrix}: {len(sums)} rows for {len(faces)} faces of {args.room}")
    errors = sorted((abs(s - 1.0), i) for i, s in enumerate(sums) if i not in skip)
    result = {"rows_checked": len(errors), "rows_left_out": len(skip), "worst": errors[-1][0],
              "worst_row": errors[-1][1], "p99": errors[int(0.99 * (len(errors) - 1))][0],
              "median": errors[len(errors) // 2][0]}
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{result['rows_checked']} rows checked ({result['rows_left_out']} left out): |sum - 1| worst "
              f"{result['worst']:.3g} (row {result['worst_row']}), 99th percentile {result['p99']:.3g}, "
              f"median {result['median']:.3g}")


if __name__ == "__main__":
    main()
