#!/usr/bin/env python3
"""Writes assets/controls/head_smile.json: 32 control vectors that make the
bundled head (cgal_head.off; faces -x, y up) smile and raise its eyebrows.

Each start is snapped to the mesh vertex nearest to a hand-picked place, so
the controls sit on the surface. Zero-length controls anchor the neck, the
back of the head and the crown, keeping the expression local."""
import json, math, os

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
lines = [l for l in open(os.path.join(root, "assets/models/cgal_head.off")).read().split("\n")
         if l.strip() and not l.startswith("#")]
nv = int(lines[1].split()[0])
P = [tuple(map(float, lines[2 + i].split()[:3])) for i in range(nv)]

def near(x, y, z):
    return min(P, key=lambda p: (p[0] - x) ** 2 + (p[1] - y) ** 2 + (p[2] - z) ** 2)

moves = []
# Mouth corners: up, out and back (a smile).
for s in (-1, 1):
    moves.append((near(-6.0, 7.4, 1.6 * s), (0.35, 0.55, 0.35 * s)))
    moves.append((near(-6.3, 7.5, 0.9 * s), (0.15, 0.35, 0.15 * s)))
    moves.append((near(-5.6, 8.6, 2.3 * s), (0.05, 0.35, 0.15 * s)))   # cheeks rise
    moves.append((near(-5.0, 9.6, 2.9 * s), (0.0, 0.2, 0.1 * s)))
    moves.append((near(-6.2, 12.7, 1.4 * s), (-0.05, 0.45, 0.0)))       # eyebrows rise
    moves.append((near(-5.6, 12.9, 2.6 * s), (0.0, 0.35, 0.05 * s)))
moves.append((near(-6.6, 7.6, 0.0), (0.1, 0.2, 0.0)))                   # upper lip
moves.append((near(-6.6, 6.9, 0.0), (0.1, -0.1, 0.0)))                  # lower lip
moves.append((near(-7.3, 11.0, 0.0), (0.0, 0.0, 0.0)))                  # nose tip stays
moves.append((near(-6.4, 5.3, 0.0), (0.0, 0.0, 0.0)))                   # chin stays
# Anchors: neck, back, crown, sides.
for (x, y, z) in [(-4.4, 1.0, 0.0), (3.4, 1.0, 0.0), (0.0, 1.0, 4.2), (0.0, 1.0, -4.2),
                  (4.5, 8.0, 0.0), (6.5, 11.0, 0.0), (0.0, 17.3, 0.0), (-3.5, 16.0, 0.0),
                  (2.0, 10.0, 4.3), (2.0, 10.0, -4.3), (-1.0, 13.0, 4.1), (-1.0, 13.0, -4.1),
                  (-2.5, 6.0, 3.9), (-2.5, 6.0, -3.9), (4.0, 14.5, 0.0), (-6.0, 15.0, 0.0),
                  (1.0, 4.0, 3.9), (1.0, 4.0, -3.9)]:
    moves.append((near(x, y, z), (0.0, 0.0, 0.0)))

seen, controls = set(), []
for p, d in moves:
    if p in seen:
        continue
    seen.add(p)
    controls.append({"from": list(p), "to": [round(p[k] + 1.8 * d[k], 6) for k in range(3)]})

doc = {"kernel": "c2", "radius": 3.5, "polynomial": "none", "controls": controls}
with open(os.path.join(root, "assets/controls/head_smile.json"), "w") as f:
    json.dump(doc, f, indent=1)
print(len(controls), "controls")
