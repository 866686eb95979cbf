"""Runs an installed csrbf wheel through its main calls and saves what they
give, so the same script under two platforms' Pythons can be compared:

    python wheel_smoke.py ASSETS OUT.npz

ASSETS is the repository's assets/ folder. Deforms the bundled head by its
smile control file (deform_mesh and a Session), fits and evaluates seeded
random controls in float32 and float64, solves several destinations on all
cores (solve_many, deform_many), writes and reads a mesh back, and checks
that a bad radius is a csrbf.Error naming it. Uses numpy and csrbf only.
"""

import os
import sys
import tempfile

import numpy as np

import csrbf

assets, out = sys.argv[1], sys.argv[2]
head = os.path.join(assets, "models", "cgal_head.off")
smile = os.path.join(assets, "controls", "head_smile.json")
results = {}

mesh = csrbf.read_mesh(head)
moved, report = csrbf.deform_mesh(mesh, smile)
results["deform_mesh"] = moved.vertices
results["report"] = np.array([report.moved, report.inside_out_faces, report.largest_move], dtype=np.float64)

session = csrbf.Session(mesh)
results["session"] = session.update_positions(smile, 0.5)

rng = np.random.default_rng(7)
points = rng.uniform(-1.0, 1.0, (20_000, 3))
starts = points[rng.choice(len(points), 200, replace=False)]
targets = starts + rng.normal(0.0, 0.02, starts.shape)
d = csrbf.fit(starts, targets, radius=0.4, kernel="c2", polynomial="linear")
results["deform64"] = d.deform(points, phase=0.7)
results["deform32"] = d.deform(points.astype(np.float32))
system = csrbf.System(starts, 0.4)
many = system.solve_many(np.stack([targets, 2 * targets - starts, starts]))
results["solve_many"] = np.stack([m.displacements(points) for m in many])
results["deform_many"] = csrbf.deform_many(points.astype(np.float32), starts, np.stack([targets, starts]), 0.4)

with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "smile.ply")
    csrbf.write_mesh(moved, path)
    results["round_trip"] = csrbf.read_mesh(path).vertices

try:
    csrbf.fit(starts, targets, radius=-1.0)
    sys.exit("wheel smoke: a radius of -1 was accepted")
except csrbf.Error as e:
    if "radius" not in str(e):
        sys.exit(f"wheel smoke: the error for a radius of -1 does not name it: {e}")

np.savez(out, **results)
print(f"wheel smoke: csrbf {csrbf.__version__} ({csrbf.build_profile}) on {sys.platform}, numpy {np.__version__}: "
      f"head {report.moved} moved, {report.inside_out_faces} inside out; {len(results)} results saved")
