"""The surfaces of a View3D 4.0 input file (.vs3), for the checking scripts beside it (python3
standard library only): `V id x y z` vertex lines and `S id v1 v2 v3 v4 ...` surface lines (a 0 for
v4 makes a triangle), read up to the `End` line; other lines are ignored."""


def read_vs3(path):
    """The surfaces in file order, each a list of its corners as (x, y, z) tuples."""
    verts, surfs = {}, []
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "V":
                verts[int(t[1])] = tuple(float(x) for x in t[2:5])
            elif t[0] == "S":
                surfs.append([verts[int(v)] for v in t[2:6] if int(v) != 0])
            elif t[0].lower().startswith("end"):
                break
    return surfs
