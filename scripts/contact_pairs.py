#!/usr/bin/env python3
"""Contact pairs of a many-faces room: every lowest side quad of a table leg against each floor quad
its bottom edge lies on, the exact factor beside the computed ones (python3 standard library only).

    python3 scripts/contact_pairs.py ROOM.vs3 [--photometria FACES.csv] [--view3d OUT.txt]

ROOM.vs3 from `meshes/make_meshes.py --many-faces H ROOM.vs3`; FACES.csv from `photometria
viewfactors ROOM.vs3 --by face -o FACES.csv`; OUT.txt from View3D 4.0 (`view3d ROOM.vs3 OUT.txt`,
its default text output). Prints one line per pair and, with --json, a summary.

The exact factor: a leg is a convex box, so its face sees exactly the part of the floor quad in front
of the face's plane, and nothing else in the room comes between them. Leg face and that part are
perpendicular rectangles, whose factor is the superposition of Howell's case C-14 (J. R. Howell, "A
Catalog of Radiation Heat Transfer Configuration Factors", 3rd ed.) as written by Ehlert & Smith,
"View factors for perpendicular and parallel rectangular plates", J. Thermophysics Heat Transfer
7(1), 1993, eq. 5:
  A_P F_PQ = (1/2 pi) sum_{ijkl} (-1)^(i+j+k+l) Gq(x_i - xi_k, y_j, eta_l),
  Gq(x, y, eta) = x sqrt(y^2+eta^2) atan(x / sqrt(y^2+eta^2)) - 1/4 (y^2 + eta^2 - x^2) ln(x^2+y^2+eta^2),
x along the planes' common line, y and eta the distances from it on P and Q.
"""

import argparse
import json
import math
import sys

from vs3 import read_vs3  # scripts/vs3.py


def gq(x, y, eta):
    r2 = y * y + eta * eta
    t2 = x * x + r2
    if t2 == 0.0:
        return 0.0
    first = x * math.sqrt(r2) * math.atan(x / math.sqrt(r2)) if r2 > 0.0 else 0.0
    return first - 0.25 * (r2 - x * x) * math.log(t2)


def perpendicular(xp, yp, xq, eq):
    """A_P F_PQ for P = xp x yp, Q = xq x eq (intervals; y, eta >= 0 distances from the common line)."""
    s = 0.0
    for i, x in enumerate(xp):
        for j, y in enumerate(yp):
            for k, xi in enumerate(xq):
                for l, e in enumerate(eq):
                    s += (-1) ** (i + j + k + l) * gq(x - xi, y, e)
    return abs(s) / (2.0 * math.pi)


def box(poly):
    return [(min(p[k] for p in poly), max(p[k] for p in poly)) for k in range(3)]


def contact_pairs(surfs, tol=1e-9):
    """(leg face, floor quad, exact F_leg->floor): y is up, the floor is y = 0."""
    floors = [i for i, s in enumerate(surfs) if all(abs(p[1]) < tol for p in s)]
    floors = [i for i in floors if area_normal(surfs[i])[1] > 0]
    pairs = []
    for i, s in enumerate(surfs):
        b = box(s)
        if abs(b[1][0]) > tol or b[1][1] < tol:  # vertical and standing on y = 0
            continue
        n = area_normal(s)
        axis = 0 if abs(n[0]) > abs(n[2]) else 2  # the face's plane is x = c or z = c
        if abs(n[1]) > tol * 1e3 or b[axis][1] - b[axis][0] > tol:
            continue
        other = 2 - axis
        c, sign = b[axis][0], (1.0 if n[axis] > 0 else -1.0)
        for j in floors:
            fb = box(surfs[j])
            if not (fb[axis][0] - tol <= c <= fb[axis][1] + tol and fb[other][0] - tol <= b[other][0]
                    and b[other][1] <= fb[other][1] + tol):
                continue
            # The floor part in front of the leg face, as distances from the common line.
            lo, hi = (c, fb[axis][1]) if sign > 0 else (fb[axis][0], c)
            if hi - lo <= tol:
                continue
            eta = (abs(lo - c), abs(hi - c))
            area_leg = (b[other][1] - b[other][0]) * (b[1][1] - b[1][0])
            af = perpendicular(b[other], b[1], fb[other], (min(eta), max(eta)))
            pairs.append((i, j, af / area_leg))
    return pairs


def area_normal(poly):
    n = [0.0, 0.0, 0.0]
    for k in range(1, len(poly) - 1):
        a = [poly[k][m] - poly[0][m] for m in range(3)]
        b = [poly[k + 1][m] - poly[0][m] for m in range(3)]
        n[0] += a[1] * b[2] - a[2] * b[1]
        n[1] += a[2] * b[0] - a[0] * b[2]
        n[2] += a[0] * b[1] - a[1] * b[0]
    return n


def read_rows_csv(path, wanted):
    rows = {}
    with open(path) as f:
        next(f)
        for i, line in enumerate(f):
            if i in wanted:
                rows[i] = [float(v) for v in line.rstrip("\n").split(",")[2:]]
    return rows


def read_rows_view3d(path, wanted):
    rows = {}
    with open(path) as f:
        next(f), next(f)
        for i, line in enumerate(f):
            if i in wanted:
                rows[i] = [float(v) for v in line.split()]
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("room")
    ap.add_argument("--photometria")
    ap.add_argument("--view3d")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    pairs = contact_pairs(read_vs3(args.room))
    if not pairs:
        sys.exit(f"{args.room}: no contact pairs found")
    wanted = {i for i, _, _ in pairs}
    sources = {}
    if args.photometria:
        sources["photometria"] = read_rows_csv(args.photometria, wanted)
    if args.view3d:
        sources["view3d"] = read_rows_view3d(args.view3d, wanted)
    worst = {k: 0.0 for k in sources}
    for i, j, exact in pairs:
        line = f"leg face {i} -> floor {j}: exact {exact:.10f}"
        for k, rows in sources.items():
            v = rows[i][j]
            worst[k] = max(worst[k], abs(v - exact))
            line += f"  {k} {v:.10f} ({v - exact:+.2e})"
        if not args.json:
            print(line)
    summary = {"pairs": len(pairs), "max_abs_error": worst}
    print(json.dumps(summary) if args.json else f"{len(pairs)} pairs, worst |error|: {worst}")


if __name__ == "__main__":
    main()
