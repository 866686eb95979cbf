"""The fold check against a dense reference, and sweeps on the same edits.

For seeded edits of models csrbf's tests never see (`../shared/models`,
or any given with --model), compares what `csrbf.deform_mesh` reports
(inside-out faces, the phase folding starts) with a reference computed
here independently: the Jacobian of the map at every triangle's centroid
by central differences of the fitted displacement (f64), det(I + t G) on a
grid of 2000 phases. Then the same edit with `"sweep": true`: inside-out
faces (should be none at any phase), the starts' landing error (a mesh made
of the starts, deformed), the steps and the time against the single map.
Not a test:

    .venv-py/bin/python crates/csrbf-py/bench/fold_truth.py [--edits 24] [--model M ...]
"""

import argparse
import time
from pathlib import Path

import numpy as np

import csrbf

ROOT = Path(__file__).resolve().parents[3]
UNSEEN = ["cgal_elephant.off", "cgal_armadillo.off", "cgal_bunny00.off", "cgal_mannequin-devil.off",
          "cgal_pig.stl", "panda3d_teapot.obj", "snowden_lo.obj"]


def reference(mesh, spec):
    """Inside-out centroid count at phase 1 and the first folding phase (to
    1/2000), from central differences of the fitted map."""
    v = mesh.vertices.astype(np.float64)
    tris = np.array([t for f in mesh.faces for t in fan(f)], np.int64)
    c = v[tris].mean(axis=1)
    starts = np.array([x["from"] for x in spec["controls"]], np.float64)
    targets = np.array([x["to"] for x in spec["controls"]], np.float64)
    d = csrbf.fit(starts, targets, spec["radius"], spec["kernel"])
    h = 1e-5 * mesh.diagonal
    g = np.empty((len(c), 3, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        g[:, :, k] = (d.displacements(c + e) - d.displacements(c - e)) / (2 * h)
    eye = np.eye(3)
    folded = int((np.linalg.det(eye + g) <= 0).sum())
    phase = None
    for t in np.linspace(0, 1, 2001)[1:]:
        if (np.linalg.det(eye + t * g) <= 0).any():
            phase = float(t)
            break
    return folded, phase


def swept_inside_out(mesh, spec, phase):
    """Centroids where the map (deform_mesh's, f32 out) has det J <= 0, by
    central differences of 1e-3 of the diagonal."""
    v = mesh.vertices.astype(np.float64)
    tris = np.array([t for f in mesh.faces for t in fan(f)], np.int64)
    c = v[tris].mean(axis=1)
    h = 1e-3 * mesh.diagonal
    probes = np.concatenate([c + s * h * np.eye(3)[k] for k in range(3) for s in (1, -1)])
    pts = csrbf.Mesh(probes.astype(np.float32), triangles=np.array([[0, 1, 2]]))
    out = csrbf.deform_mesh(pts, spec, phase=phase)[0].vertices.astype(np.float64).reshape(3, 2, len(c), 3)
    jac = (out[:, 0] - out[:, 1]).transpose(1, 2, 0) / (2 * h)  # [centroid, row, column]
    return int((np.linalg.det(jac) <= 0).sum())


def fan(face):
    return [(face[0], face[i], face[i + 1]) for i in range(1, len(face) - 1)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--edits", type=int, default=24)
    ap.add_argument("--model", action="append")
    ap.add_argument("--dump", help="write each edit's control file (with the sweep) into this folder")
    args = ap.parse_args()
    shared = ROOT.parent / "shared" / "models"
    models = [Path(m) for m in args.model] if args.model else [shared / m for m in UNSEEN if (shared / m).exists()]
    if not models:
        raise SystemExit(f"no models: give --model, or put the unseen models in {shared}")
    rng = np.random.default_rng(23)
    rows = []
    for e in range(args.edits):
        path = models[e % len(models)]
        mesh = csrbf.read_mesh(path)
        v = mesh.vertices.astype(np.float64)
        k = int(rng.integers(2, 19))
        radius = float(rng.uniform(0.05, 0.2)) * mesh.diagonal
        starts = v[rng.choice(len(v), size=k, replace=False)]
        dirs = rng.normal(size=(k, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        moves = dirs * rng.uniform(0.05, 1.2, size=(k, 1)) * radius
        spec = {"radius": radius, "kernel": str(rng.choice(["c0", "c2", "c4", "c6"])),
                "controls": [{"from": s.tolist(), "to": (s + m).tolist()} for s, m in zip(starts, moves)]}
        try:
            t0 = time.perf_counter()
            _, plain = csrbf.deform_mesh(mesh, spec)
            plain_s = time.perf_counter() - t0
        except csrbf.Error:
            continue  # starts too close for this radius: not an edit
        folded, phase = reference(mesh, spec)
        t0 = time.perf_counter()
        try:
            _, swept = csrbf.deform_mesh(mesh, {**spec, "sweep": True})
        except csrbf.Error as err:
            rows.append((path.name, k, spec["kernel"], plain, folded, phase, None, str(err), plain_s, 0.0))
            continue
        sweep_s = time.perf_counter() - t0
        if args.dump:
            import json
            Path(args.dump).mkdir(exist_ok=True)
            (Path(args.dump) / f"edit{e:02d}_{path.stem}.json").write_text(json.dumps({**spec, "sweep": True}))
        # Measured through deform_mesh, not taken from the certificate: det J
        # of the whole swept map by central differences at every centroid.
        worst_half = max(swept_inside_out(mesh, {**spec, "sweep": True}, p) for p in (0.25, 0.5, 0.75, 1.0))
        pts = csrbf.Mesh(np.vstack([starts, [v.max(0) + mesh.diagonal]]).astype(np.float32),
                         triangles=np.array([[0, 1, k]]))
        landed, _ = csrbf.deform_mesh(pts, {**spec, "sweep": True})
        miss = float(np.linalg.norm(landed.vertices[:k] - (starts + moves), axis=1).max()) / mesh.diagonal
        info = (swept.inside_out_faces, worst_half, miss)
        rows.append((path.name, k, spec["kernel"], plain, folded, phase, info, "", plain_s, sweep_s))
    print(f"{'model':<26}{'k':>3} {'ker':<4}{'csrbf':>7}{'dense':>7}{'phase':>8}{'dense':>8}"
          f"{'swept':>7}{'dense':>6}{'miss/diag':>11}{'plain s':>9}{'sweep s':>9}")
    agree = n = 0
    phase_ok = phases = 0
    for name, k, ker, plain, folded, phase, info, err, ps, ss in rows:
        n += 1
        ok = abs(plain.inside_out_faces - folded) <= 0.1 * folded + 2
        agree += ok
        if (plain.fold_phase is None) != (phase is None):
            pass
        elif phase is not None:
            phases += 1
            phase_ok += abs(plain.fold_phase - phase) <= 0.02
        fp = "-" if plain.fold_phase is None else f"{plain.fold_phase:.3f}"
        rp = "-" if phase is None else f"{phase:.3f}"
        if info is None:
            print(f"{name:<26}{k:>3} {ker:<4}{plain.inside_out_faces:>7}{folded:>7}{fp:>8}{rp:>8}  sweep refused: {err}")
            continue
        print(f"{name:<26}{k:>3} {ker:<4}{plain.inside_out_faces:>7}{folded:>7}{fp:>8}{rp:>8}"
              f"{info[0]:>7}{info[1]:>6}{info[2]:>11.1e}{ps:>9.3f}{ss:>9.3f}")
    both_none = sum(1 for r in rows if (r[3].fold_phase is None) == (r[5] is None))
    print(f"counts within 10 % + 2 of the dense reference: {agree} of {n}; "
          f"fold phase present/absent alike: {both_none} of {n}, within 0.02: {phase_ok} of {phases}")


if __name__ == "__main__":
    main()
