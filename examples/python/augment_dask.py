"""Dataset augmentation on a Dask cluster: every mesh of a folder deformed by
K random local edits, written beside each other as new mesh files.

    python augment_dask.py MESHES/ --out AUGMENTED/ --variants 100
    python augment_dask.py MESHES/ --out AUGMENTED/ --scheduler tcp://10.0.0.5:8786

Without --scheduler it starts a LocalCluster on this machine (--workers
processes, one thread each: csrbf already uses every core of a worker). With
--scheduler ADDRESS it runs on that cluster: every worker needs `csrbf`
installed (pip install crates/csrbf-py) and must see the input and output
folders at the same paths (a shared filesystem); nothing else changes.

Each task is one mesh: it picks --controls starts among the mesh's vertices
and K sets of destinations (seeded by the mesh's name and --seed, so a run is
reproducible on any cluster), deforms the mesh by all K in one call
(csrbf.deform_many: the system is factored once, the K solves run in
parallel, each variant is the kernel sums through one binding) and writes NAME_vNNN.EXT.
"""

from __future__ import annotations

import argparse
import sys
import time
import zlib
from pathlib import Path

import numpy as np

import csrbf

FORMATS = (".obj", ".ply", ".off", ".stl", ".gltf", ".glb")


def edits(vertices: np.ndarray, variants: int, controls: int, radius_share: float, seed: int):
    """Starts (vertices of the mesh), K destination sets and the radius for one mesh."""
    rng = np.random.default_rng(seed)
    points = vertices.astype(np.float64)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    radius = radius_share * diagonal
    starts = np.unique(points[rng.choice(len(points), size=min(controls, len(points)), replace=False)], axis=0)
    # Moves of about a fifth of R: well inside the kernel's fold-free bound.
    moves = rng.normal(0.0, 0.2 * radius / np.sqrt(3), (variants, *starts.shape))
    return starts, starts + moves, radius


def seed_of(path: Path, seed: int) -> int:
    return zlib.crc32(path.name.encode()) ^ seed


def augment(path: str, out_dir: str, variants: int, controls: int, radius_share: float, seed: int) -> dict:
    """One task: a mesh deformed by `variants` random edits, each written out."""
    t0 = time.perf_counter()
    src = Path(path)
    mesh = csrbf.read_mesh(src)
    starts, targets, radius = edits(mesh.vertices, variants, controls, radius_share, seed_of(src, seed))
    moved = csrbf.deform_many(mesh.vertices, starts, targets, radius)
    suffix = ".ply" if src.suffix == ".stl" else src.suffix  # STL cannot keep vertex order
    for k in range(variants):
        variant = mesh.copy()
        variant.vertices = moved[k]
        csrbf.write_mesh(variant, Path(out_dir) / f"{src.stem}_v{k:03d}{suffix}")
    return {"mesh": src.name, "vertices": len(mesh), "variants": variants, "seconds": time.perf_counter() - t0}


def progress_bar(done: int, total: int, width: int = 30) -> None:
    filled = width * done // max(total, 1)
    sys.stderr.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} meshes")
    sys.stderr.flush()


def run(folder, out_dir, variants=10, controls=16, radius_share=0.1, seed=0, scheduler=None, workers=2, quiet=False):
    """Runs the augmentation on a cluster; returns each task's summary."""
    from dask.distributed import Client, LocalCluster, as_completed

    meshes = sorted(str(p) for p in Path(folder).iterdir() if p.suffix.lower() in FORMATS)
    if not meshes:
        raise SystemExit(f"no mesh files ({', '.join(FORMATS)}) in {folder}")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        futures = [
            client.submit(augment, m, str(out_dir), variants, controls, radius_share, seed, pure=False)
            for m in meshes
        ]
        results = []
        if not quiet:
            progress_bar(0, len(futures))
        for future in as_completed(futures):
            results.append(future.result())
            if not quiet:
                progress_bar(len(results), len(futures))
        if not quiet:
            sys.stderr.write("\n")
        return sorted(results, key=lambda r: r["mesh"])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def main(argv=None) -> None:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("folder", help="folder of meshes (.obj .ply .off .stl .gltf .glb)")
    a.add_argument("--out", required=True, help="folder for the variants")
    a.add_argument("--variants", type=int, default=10, help="edits per mesh (K)")
    a.add_argument("--controls", type=int, default=16, help="control vectors per edit")
    a.add_argument("--radius-share", type=float, default=0.1, help="R as a share of each mesh's diagonal")
    a.add_argument("--seed", type=int, default=0)
    a.add_argument("--scheduler", help="address of a running Dask scheduler (default: a LocalCluster here)")
    a.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    a.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    args = a.parse_args(argv)
    t0 = time.perf_counter()
    results = run(args.folder, args.out, args.variants, args.controls, args.radius_share, args.seed,
                  args.scheduler, args.workers, args.quiet)
    for r in results:
        print(f"{r['mesh']}: {r['variants']} variants of {r['vertices']} vertices in {r['seconds']:.2f} s")
    print(f"{sum(r['variants'] for r in results)} meshes written to {args.out} in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
