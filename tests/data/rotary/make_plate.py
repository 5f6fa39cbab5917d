"""Writes plate.stl: a box 40 x (pi * 30) x 2 mm, the unwrapped shell of a 30 mm mandrel."""
import math
import sys

X, Y, Z = 40.0, math.pi * 30.0, 2.0
v = [(x, y, z) for x in (0, X) for y in (0, Y) for z in (0, Z)]
# Two triangles per face, wound counter-clockwise seen from outside.
faces = [(0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3), (0, 4, 5), (0, 5, 1),
         (2, 3, 7), (2, 7, 6), (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5)]
out = ["solid plate"]
for a, b, c in faces:
    p, q, r = v[a], v[b], v[c]
    u = [q[i] - p[i] for i in range(3)]
    w = [r[i] - p[i] for i in range(3)]
    n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    s = math.sqrt(sum(k * k for k in n))
    out.append("facet normal %g %g %g" % tuple(k / s for k in n))
    out.append("outer loop")
    out += ["vertex %.6f %.6f %.6f" % v[i] for i in (a, b, c)]
    out += ["endloop", "endfacet"]
out.append("endsolid plate")
open(sys.argv[1] if len(sys.argv) > 1 else "plate.stl", "w").write("\n".join(out) + "\n")
