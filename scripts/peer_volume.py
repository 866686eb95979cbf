#!/usr/bin/env python3
"""What a CFD/FEA user would run instead of csrbf to morph a volume mesh from its
boundary, timed in one run with `csrbf bench` on the same files (issue 43's figures):

- sparse: the same Wendland interpolant through cKDTree, scipy.sparse and CHOLMOD
  (scripts/peer_pipeline.py's pipeline, no polynomial: as csrbf's boundary morph);
- SciPy's RBFInterpolator(neighbors=50) (a multiquadric on each point's 50 nearest
  controls, a constant polynomial: a box's flat side leaves a linear one singular);
- a PyGeM-style dense RBF (the Wendland matrix dense, numpy's solve, the evaluation
  in blocks), when the matrix fits in memory (--dense-max controls, 20k by default);
- the cell check: signed volumes of the morphed tetrahedra with numpy.

    target/release/csrbf bench --scene volume/56/1/20 --export DIR
    python scripts/peer_volume.py DIR/volume-56-1-20.vtu DIR/volume-56-1-20.json [--csrbf target/release/csrbf]

Needs (not in CI): pip scipy meshio cholespy (or scikit-sparse).
"""

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import meshio
import numpy as np
from scipy.interpolate import RBFInterpolator

sys.path.insert(0, str(Path(__file__).resolve().parent))
import peer_pipeline as pp  # noqa: E402


def prescribed(mesh, morph):
    """Boundary nodes and displacements as csrbf's boundary morph makes them:
    the nodes of each moved zone by its translation (the first zone wins), the
    held zones' nodes at zero."""
    names = {name: int(v[0]) for name, v in mesh.field_data.items()}
    tags = mesh.cell_data["gmsh:physical"]
    nodes_of = {}
    for block, t in zip(mesh.cells, tags):
        t = np.asarray(t).ravel()
        for tag in np.unique(t):
            nodes_of.setdefault(int(tag), []).append(np.unique(block.data[t == tag]))
    zone = lambda name: np.unique(np.concatenate(nodes_of[names.get(name, -1)]))  # noqa: E731
    disp = {}
    for m in morph["move"]:
        for v in zone(m["zone"]):
            disp.setdefault(int(v), np.asarray(m["translate"], float))
    for name in morph.get("hold", []):
        for v in zone(name):
            disp.setdefault(int(v), np.zeros(3))
    nodes = np.array(sorted(disp))
    return nodes, np.array([disp[v] for v in nodes])


def inverted(points, tets):
    p = points[tets]
    vol = np.einsum("ij,ij->i", p[:, 3] - p[:, 0], np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
    return int((vol <= 0).sum())


def peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("morph")
    ap.add_argument("--csrbf", default="target/release/csrbf")
    ap.add_argument("--dense-max", type=int, default=20000)
    ap.add_argument("--skip-rbfinterpolator", action="store_true")
    a = ap.parse_args()
    mesh = meshio.read(a.mesh)
    morph = json.load(open(a.morph))["boundary"]
    radius, kernel = morph["radius"], morph.get("kernel", "c2")
    tets = np.concatenate([b.data for b in mesh.cells if b.type == "tetra"])
    points = mesh.points
    t = time.perf_counter()
    nodes, disp = prescribed(mesh, morph)
    starts = points[nodes]
    out = {"nodes": len(points), "tetrahedra": len(tets), "controls": len(nodes), "prescribe_s": time.perf_counter() - t}

    # The sparse pipeline (no polynomial: csrbf's boundary morph has none).
    t = time.perf_counter()
    tree = pp.cKDTree(starts)
    d = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    a_ = pp.sparse.csc_matrix((pp.KERNELS[kernel](d.data / radius), (d.row, d.col)), shape=(len(nodes),) * 2)
    coef = pp.cholesky(a_)(disp)
    fit_s = time.perf_counter() - t
    t = time.perf_counter()
    e = tree.sparse_distance_matrix(pp.cKDTree(points), radius, output_type="coo_matrix")
    b = pp.sparse.csr_matrix((pp.KERNELS[kernel](e.data / radius), (e.col, e.row)), shape=(len(points), len(nodes)))
    moved = points + b @ coef
    moved[nodes] = starts + disp
    eval_s = time.perf_counter() - t
    t = time.perf_counter()
    bad = inverted(moved, tets)
    out["sparse"] = {"fit_s": fit_s, "evaluate_s": eval_s, "check_s": time.perf_counter() - t, "inverted": bad, "cholmod": pp.CHOLMOD, "peak_mb": peak_mb()}
    print(json.dumps({"sparse": out["sparse"]}), flush=True)

    if not a.skip_rbfinterpolator:
        t = time.perf_counter()
        # A box's side is flat: 50 neighbours on it leave a linear
        # polynomial singular, so a kernel that needs only a constant.
        rbf = RBFInterpolator(starts, disp, neighbors=50, kernel="multiquadric", epsilon=1 / radius, degree=0)
        fit_s = time.perf_counter() - t
        t = time.perf_counter()
        moved = points + rbf(points)
        eval_s = time.perf_counter() - t
        out["rbfinterpolator_50"] = {"fit_s": fit_s, "evaluate_s": eval_s, "inverted": inverted(moved, tets), "peak_mb": peak_mb()}
        print(json.dumps({"rbfinterpolator_50": out["rbfinterpolator_50"]}), flush=True)

    if len(nodes) <= a.dense_max:
        t = time.perf_counter()
        from scipy.spatial.distance import cdist

        r = cdist(starts, starts) / radius
        dense = np.where(r < 1, pp.KERNELS[kernel](np.minimum(r, 1)), 0.0)
        del r
        coef = np.linalg.solve(dense, disp)
        del dense
        fit_s = time.perf_counter() - t
        t = time.perf_counter()
        moved = points.copy()
        for i in range(0, len(points), 4096):
            r = cdist(points[i : i + 4096], starts) / radius
            moved[i : i + 4096] += np.where(r < 1, pp.KERNELS[kernel](np.minimum(r, 1)), 0.0) @ coef
        eval_s = time.perf_counter() - t
        out["dense"] = {"fit_s": fit_s, "evaluate_s": eval_s, "inverted": inverted(moved, tets), "peak_mb": peak_mb()}
        print(json.dumps({"dense": out["dense"]}), flush=True)
    else:
        out["dense"] = f"not run: {len(nodes)} controls need a {len(nodes) ** 2 * 8 / 2**30:.1f} GiB dense matrix (--dense-max {a.dense_max})"

    runs = subprocess.run([a.csrbf, "bench", "--mesh", a.mesh, "--controls", a.morph, "--runs", "3", "--json"], capture_output=True, text=True, check=True)
    out["csrbf"] = json.loads(runs.stdout)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
