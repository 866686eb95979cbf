"""How often the fold-free bound warning agrees with the exact fold check.

For seeded random edits of the bundled models (a few control vectors,
each moved by a random share of R, kernel and R drawn too), counts how
often `csrbf deform` warns `past_fold_free_bound` and how often the map
really turns faces inside out (det J <= 0 at a centroid). Not a test:

    .venv-py/bin/python crates/csrbf-py/bench/fold_bound.py [--edits 300]
"""

import argparse
from pathlib import Path

import numpy as np

import csrbf

ROOT = Path(__file__).resolve().parents[3]
MODELS = ["cgal_head.off", "assimp_Suzanne_248.obj", "pybullet_duck.obj", "cgal_hand.off"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--edits", type=int, default=300)
    args = ap.parse_args()
    rng = np.random.default_rng(17)
    table = {(w, f): 0 for w in (False, True) for f in (False, True)}
    for e in range(args.edits):
        mesh = csrbf.read_mesh(ROOT / "assets" / "models" / MODELS[e % len(MODELS)])
        v = mesh.vertices
        k = int(rng.integers(1, 6))
        radius = float(rng.uniform(0.05, 0.3)) * mesh.diagonal
        starts = v[rng.choice(len(v), size=k, replace=False)].astype(float)
        # Moves from a tenth to twice the C2 bound (0.474 R), in random directions.
        dirs = rng.normal(size=(k, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        lengths = rng.uniform(0.05, 1.0, size=(k, 1)) * radius
        spec = {
            "radius": radius,
            "kernel": str(rng.choice(["c0", "c2", "c4", "c6"])),
            "controls": [{"from": s.tolist(), "to": (s + d).tolist()} for s, d in zip(starts, dirs * lengths)],
        }
        try:
            _, report = csrbf.deform_mesh(mesh, spec)
        except csrbf.Error:
            continue  # starts too close for this radius: not an edit
        warned = "past_fold_free_bound" in report.warning_kinds
        table[(warned, report.inside_out_faces > 0)] += 1
    n = sum(table.values())
    print(f"{n} edits of the bundled models (1-5 vectors, R 5-30 % of the diagonal, moves 0.05-1 R)")
    print(f"  warned and folds:        {table[(True, True)]}")
    print(f"  warned, does not fold:   {table[(True, False)]}")
    print(f"  not warned, folds:       {table[(False, True)]}")
    print(f"  not warned, no fold:     {table[(False, False)]}")
    right = table[(True, True)] + table[(False, False)]
    print(f"  the warning is right in {right} of {n} ({100 * right / max(n, 1):.0f} %)")


if __name__ == "__main__":
    main()
