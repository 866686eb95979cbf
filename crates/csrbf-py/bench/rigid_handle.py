"""Figures of issue 42 (not a test): a rigid handle's fit and drag step, and
the symmetry search on a million points.

- the armadillo of ../shared/models, its arm (a sphere of 22 about (55, 60,
  -30)) turned 75 degrees about the shoulder (35, 50, -30), R 25, a region
  60 along the surface from the handle, an anchor on the chest: the first
  `Session.update` (fit, deform, checks) and a drag step (the angle +0.5
  degree, `update_positions`), medians; the arm's pairwise distances and the
  anchor's largest move at full phase;
- `find_symmetry` (any orientation) and `symmetry_plane` (normal to X) on a
  million points of an egg symmetric about one plane, turned 15 degrees.

Run with a release build of the package installed (`pip install crates/csrbf-py`
or a release wheel):

    python crates/csrbf-py/bench/rigid_handle.py [path/to/cgal_armadillo.off]
"""

import statistics
import sys
import time
from pathlib import Path

import numpy as np

import csrbf

ROOT = Path(__file__).resolve().parents[3]
ARMADILLO = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "models" / "cgal_armadillo.off"
ARM = {
    "radius": 25,
    "region": {"connected": {"distance": 60, "from": "handle"}},
    "handle": {
        "select": {"sphere": {"center": [55, 60, -30], "radius": 22}},
        "rotate": {"axis": [0, 0, 1], "angle_deg": -75, "pivot": [35, 50, -30]},
    },
    "anchor": {"sphere": {"center": [5, 40, -20], "radius": 22}},
}


def median_ms(f, runs):
    t = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        t.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(t)


def main():
    print(f"csrbf {csrbf.__version__} ({csrbf.build_profile} build)")
    if not ARMADILLO.exists():
        sys.exit(f"rigid_handle: no {ARMADILLO} (give the armadillo's path)")
    mesh = csrbf.read_mesh(ARMADILLO)
    p = mesh.vertices.astype(np.float64)
    session = csrbf.Session(mesh)
    t0 = time.perf_counter()
    report = session.update(ARM, remedies="off")
    first = (time.perf_counter() - t0) * 1e3
    q = session.vertices.astype(np.float64)
    arm = np.flatnonzero(np.linalg.norm(p - [55, 60, -30], axis=1) <= 22)
    held = np.flatnonzero(np.linalg.norm(p - [5, 40, -20], axis=1) <= 22)
    a, b = arm[::7], arm[3::11][: len(arm[::7])]
    a, b = a[: len(b)], b
    keep = a != b
    change = np.abs(np.linalg.norm(q[a] - q[b], axis=1) / np.linalg.norm(p[a] - p[b], axis=1) - 1)[keep]
    print(f"handle: first update {first:.0f} ms, {session.controls} controls, {report.inside_out_faces} faces "
          f"inside out; arm distances change at most {100 * change.max():.3f} %, anchor moved "
          f"{np.linalg.norm(q[held] - p[held], axis=1).max():.2e}")
    angle = [-75.0]

    def step():
        angle[0] += 0.5
        ARM["handle"]["rotate"]["angle_deg"] = angle[0]
        session.update_positions(ARM)

    print(f"handle: drag step {median_ms(step, 7):.0f} ms (median of 7)")
    rng = np.random.default_rng(0)
    v = rng.normal(size=(1_000_000, 3))
    v /= np.linalg.norm(v, axis=1)[:, None]
    bump = np.array([0.0, 0.6, 0.8])
    v = v * [1.0, 0.7, 0.5] * (1 + 0.4 * np.clip(v @ bump - 0.6, 0, None))[:, None]
    c, s = np.cos(np.radians(15)), np.sin(np.radians(15))
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    pts = (v @ rot.T).astype(np.float32)
    t0 = time.perf_counter()
    _, normal = csrbf.find_symmetry(pts)
    found = (time.perf_counter() - t0) * 1e3
    off = np.degrees(np.arccos(min(1.0, abs(float(normal @ (rot @ [1.0, 0.0, 0.0]))))))
    t0 = time.perf_counter()
    csrbf.symmetry_plane(pts)
    axis = (time.perf_counter() - t0) * 1e3
    print(f"symmetry: find_symmetry on 1,000,000 points {found:.0f} ms (normal off by {off:.3f} degrees); "
          f"symmetry_plane {axis:.0f} ms")


if __name__ == "__main__":
    main()
