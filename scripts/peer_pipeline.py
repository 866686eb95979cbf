#!/usr/bin/env python3
"""What a user would assemble instead of csrbf for a big CSRBF deformation, timed in the
same run as `csrbf bench` (issue 18's ratio): SciPy's cKDTree, scipy.sparse and CHOLMOD
(scikit-sparse).

    target/release/csrbf bench --scene 1m --export DIR
    python scripts/peer_pipeline.py DIR/1m.ply DIR/1m.json [--runs 3] [--csrbf target/release/csrbf]
    target/release/csrbf bench --scene scan --mesh MESH --export DIR    (starts on a real mesh)
    python scripts/peer_pipeline.py DIR/scan-NAME.ply DIR/scan-NAME.json

Fit: the pairs of starts within R (cKDTree.sparse_distance_matrix), the Wendland matrix
A on them, CHOLMOD's Cholesky factor of A, and the linear polynomial by its Schur
complement (A c + P d = f, P^T c = 0: d from P^T A^-1 P d = P^T A^-1 f, then c).
Evaluate: the points against the starts within R (a sparse matrix), the kernel on its
entries, one sparse product, plus the polynomial. Then `csrbf bench` on the same scene
(the synthetic scene of the same name) and, with --check, csrbf deform's output compared
with the peer's. Needs (not in CI): pip scipy cholespy (CHOLMOD bundled), or apt
libsuitesparse-dev with pip "numpy<2" scikit-sparse==0.4.12 (0.5 needs SuiteSparse 7).
"""

import argparse
import json
import statistics
import subprocess
import sys
import time

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree
try:  # scikit-sparse needs SuiteSparse from apt; cholespy bundles CHOLMOD (pip)
    from sksparse.cholmod import cholesky

    CHOLMOD = "scikit-sparse"
except ImportError:
    import cholespy

    CHOLMOD = "cholespy"

    def cholesky(a):
        a = a.tocoo()
        solver = cholespy.CholeskySolverD(
            a.shape[0],
            a.row.astype(np.int32),
            a.col.astype(np.int32),
            a.data.astype(np.float64),
            cholespy.MatrixType.COO,
        )

        def solve(b):
            b = np.ascontiguousarray(b, dtype=np.float64)
            x = np.empty_like(b)
            solver.solve(b, x)
            return x

        return solve

KERNELS = {
    "c0": lambda r: (1 - r) ** 2,
    "c2": lambda r: (1 - r) ** 4 * (4 * r + 1),
    "c4": lambda r: (1 - r) ** 6 * ((35 * r + 18) * r + 3),
}


def read_ply_points(path):
    """The vertices of a binary little-endian or ASCII PLY with float x, y, z first."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline()
            if not line:
                sys.exit(f"{path}: no end_header")
            line = line.decode("ascii", "replace").strip()
            header.append(line)
            if line == "end_header":
                break
        fmt = next(h.split()[1] for h in header if h.startswith("format"))
        n = next(int(h.split()[2]) for h in header if h.startswith("element vertex"))
        props = []
        in_vertex = False
        for h in header:
            if h.startswith("element"):
                in_vertex = h.startswith("element vertex")
            elif in_vertex and h.startswith("property"):
                props.append(h.split())
        if any(p[1] not in ("float", "float32") for p in props):
            sys.exit(f"{path}: only float vertex properties are read here")
        if fmt == "binary_little_endian":
            data = np.frombuffer(f.read(n * 4 * len(props)), dtype="<f4")
            return data.reshape(n, len(props))[:, :3].astype(np.float64)
        rows = [f.readline().split()[:3] for _ in range(n)]
        return np.array(rows, dtype=np.float64)


def fit(starts, targets, radius, kernel):
    tree = cKDTree(starts)
    d = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    values = KERNELS[kernel](d.data / radius)
    n = len(starts)
    # Pairs at distance 0 (the diagonal) are listed too, as explicit entries.
    a = sparse.csc_matrix((values, (d.row, d.col)), shape=(n, n))
    factor = cholesky(a)
    p = np.hstack([np.ones((n, 1)), starts])
    f = targets - starts
    ainv_f = factor(f)
    ainv_p = factor(p)
    dcoef = np.linalg.solve(p.T @ ainv_p, p.T @ ainv_f)
    c = factor(f - p @ dcoef)
    return tree, c, dcoef


def evaluate(points, tree, c, dcoef, radius, kernel):
    m = cKDTree(points).sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    values = KERNELS[kernel](m.data / radius)
    e = sparse.csr_matrix((values, (m.row, m.col)), shape=(len(points), len(c)))
    out = e @ c + np.hstack([np.ones((len(points), 1)), points]) @ dcoef
    return out, m.nnz


def median_time(runs, f):
    """The median of `runs` timed calls after untimed ones, as `csrbf bench` warms up: at
    least 3 and for 100 ms at least, or one when a call takes a second."""
    start, result, calls = time.perf_counter(), f(), 1
    while True:
        ms = (time.perf_counter() - start) * 1e3
        if ms >= 1000 or (calls >= 3 and ms >= 100):
            break
        result, calls = f(), calls + 1
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        result = f()
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times), result


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh")
    ap.add_argument("controls")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--csrbf", default="target/release/csrbf")
    ap.add_argument(
        "--scene",
        help="a synthetic scene for csrbf bench to run (default: the same mesh and controls)",
    )
    ap.add_argument("--check", action="store_true", help="compare with csrbf deform's output")
    args = ap.parse_args()

    spec = json.load(open(args.controls))
    kernel, radius = spec.get("kernel", "c2"), spec["radius"]
    if spec.get("polynomial", "linear") != "linear" or kernel not in KERNELS:
        sys.exit("only a linear polynomial and kernels c0, c2, c4 are done here")
    starts = np.array([c["from"] for c in spec["controls"]], dtype=np.float64)
    targets = np.array([c["to"] for c in spec["controls"]], dtype=np.float64)
    points = read_ply_points(args.mesh)
    print(f"{args.mesh}: {len(points)} points, {len(starts)} controls, R {radius:.4f}, {kernel}")

    fit_ms, (tree, c, dcoef) = median_time(args.runs, lambda: fit(starts, targets, radius, kernel))
    eval_ms, (disp, nnz) = median_time(
        args.runs, lambda: evaluate(points, tree, c, dcoef, radius, kernel)
    )
    print(
        f"peer (cKDTree + scipy.sparse + CHOLMOD via {CHOLMOD}): fit {fit_ms:.0f} ms, evaluate {eval_ms:.0f} ms "
        f"({nnz} kernel evaluations), fit + evaluate {fit_ms + eval_ms:.0f} ms (medians of {args.runs})"
    )
    scene = ["--scene", args.scene] if args.scene else ["--mesh", args.mesh, "--controls", args.controls]
    out = subprocess.run(
        [args.csrbf, "bench", *scene, "--runs", str(max(args.runs, 3)), "--json"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    r = json.loads(out)
    r = r[0] if isinstance(r, list) else r
    ours = r["fit_evaluate_ms"]
    print(
        f"csrbf bench {' '.join(scene)}: fit {r['fit_ms']:.1f} ms, evaluate {r['evaluate_ms']:.1f} ms, "
        f"fit + evaluate {ours:.1f} ms"
    )
    print(
        f"ratio: fit {fit_ms / r['fit_ms']:.1f}x, evaluate {eval_ms / r['evaluate_ms']:.1f}x, "
        f"fit + evaluate {(fit_ms + eval_ms) / ours:.1f}x"
    )
    if args.check:
        moved = args.mesh + ".csrbf.ply"
        subprocess.run(
            [args.csrbf, "deform", "--mesh", args.mesh, "--controls", args.controls, "--out", moved, "-q"],
            check=True,
        )
        theirs = read_ply_points(moved) - points
        scale = np.abs(disp).max()
        print(
            f"check: csrbf deform against the peer, largest difference {np.abs(theirs - disp).max():.2e} "
            f"({np.abs(theirs - disp).max() / scale:.1e} of the largest displacement {scale:.3e})"
        )


if __name__ == "__main__":
    main()
