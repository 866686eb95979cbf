"""Figures for the Python package (a benchmark, not a test): csrbf.fit +
displacements from Python against `csrbf bench` on the same files, against
SciPy's RBFInterpolator (neighbors=50) and a PyGeM-style dense RBF where it
fits in memory, and deform_many with K = 100 target sets on 100k points.

    pip install crates/csrbf-py scipy          # a release build of the package
    cargo build --release -p csrbf-cli
    python crates/csrbf-py/bench/bench.py [--scenes 100k 1m] [--runs 5] [--json out.json] [--no-peers]

The scenes are `csrbf bench --scene NAME --export DIR` (points on a sphere,
C2, linear polynomial): the CLI times them from the same PLY and JSON files
Python reads. Medians of --runs runs, CLI and Python in 3 alternating rounds
(the slow SciPy and dense ones: 1 run,
and at 1M SciPy is timed on a 100k sample of the points and scaled, said so).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import csrbf

ROOT = Path(__file__).resolve().parents[3]
DENSE_LIMIT = 8e9  # bytes a dense evaluation may take (the machine has 23 GB)
ROUNDS = 3  # CLI and Python measured in turns


def median_ms(f, runs):
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        f()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def controls(path):
    spec = json.loads(Path(path).read_text())
    starts = np.array([c["from"] for c in spec["controls"]])
    targets = np.array([c["to"] for c in spec["controls"]])
    return starts, targets, spec["radius"], spec.get("kernel", "c2"), spec.get("polynomial", "none")


def wendland_c2(r):
    r = np.minimum(r, 1.0)
    return (1 - r) ** 4 * (4 * r + 1)


def dense_rbf(starts, targets, radius, points):
    """PyGeM's RBF (pygem.RBF): a dense (M+4)^2 system with a linear
    polynomial, then the whole (N, M) distance matrix at once. Same kernel
    and R as csrbf, so the same interpolant."""
    from scipy.spatial.distance import cdist

    m = len(starts)
    h = np.zeros((m + 4, m + 4))
    h[:m, :m] = wendland_c2(cdist(starts, starts) / radius)
    h[:m, m] = 1
    h[:m, m + 1 :] = starts
    h[m, :m] = 1
    h[m + 1 :, :m] = starts.T
    rhs = np.zeros((m + 4, 3))
    rhs[:m] = targets - starts
    weights = np.linalg.solve(h, rhs)
    e = np.empty((len(points), m + 4))
    e[:, :m] = wendland_c2(cdist(points, starts) / radius)
    e[:, m] = 1
    e[:, m + 1 :] = points
    return e @ weights


def scipy_rbf(starts, targets, points):
    from scipy.interpolate import RBFInterpolator

    return RBFInterpolator(starts, targets - starts, neighbors=50)(points)


def cli_bench(binary, mesh, ctl, runs):
    out = subprocess.run(
        [str(binary), "-q", "bench", "--mesh", str(mesh), "--controls", str(ctl), "--runs", str(runs), "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    return json.loads(out)


def scene_figures(binary, directory, name, runs, peers=True):
    mesh_path, ctl_path = directory / f"{name}.ply", directory / f"{name}.json"
    points = csrbf.read_mesh(mesh_path).vertices  # float32, as the CLI's
    starts, targets, radius, kernel, poly = controls(ctl_path)
    row = {"scene": name, "vertices": len(points), "controls": len(starts), "radius": radius}

    fit = lambda: csrbf.fit(starts, targets, radius, kernel=kernel, polynomial=poly)  # noqa: E731
    d = fit()
    out = np.empty_like(points)
    # CLI and Python take turns, ROUNDS times, so a busy minute of the
    # machine weighs on both alike; the median of the rounds' medians is kept.
    rounds = {k: [] for k in ("cli_fit_ms", "cli_evaluate_ms", "cli_fit_evaluate_ms", "py_fit_ms",
                              "py_evaluate_ms", "py_fit_evaluate_ms", "py_fit_evaluate_out_ms")}
    for _ in range(ROUNDS):
        cli = cli_bench(binary, mesh_path, ctl_path, runs)
        for k in ("fit_ms", "evaluate_ms", "fit_evaluate_ms"):
            rounds["cli_" + k].append(cli[k])
        rounds["py_fit_ms"].append(median_ms(fit, runs))
        rounds["py_evaluate_ms"].append(median_ms(lambda: d.displacements(points), runs))
        rounds["py_fit_evaluate_ms"].append(median_ms(lambda: fit().displacements(points), runs))
        rounds["py_fit_evaluate_out_ms"].append(median_ms(lambda: fit().displacements(points, out=out), runs))
    row.update({k: statistics.median(v) for k, v in rounds.items()})
    row["py_vs_cli"] = row["py_fit_evaluate_ms"] / row["cli_fit_evaluate_ms"] - 1
    if not peers:
        return row
    reference = d.displacements(points.astype(np.float64))

    p64 = points.astype(np.float64)
    if len(points) <= 200_000:
        t0 = time.perf_counter()
        got = scipy_rbf(starts, targets, p64)
        row["scipy_ms"] = (time.perf_counter() - t0) * 1e3
        row["scipy_note"] = "measured, 1 run"
    else:
        sample = p64[np.random.default_rng(0).choice(len(p64), 100_000, replace=False)]
        t0 = time.perf_counter()
        scipy_rbf(starts, targets, sample)
        row["scipy_ms"] = (time.perf_counter() - t0) * 1e3 * len(p64) / len(sample)
        row["scipy_note"] = f"timed on 100,000 of the points, scaled by {len(p64) / len(sample):.0f}"
        got = None
    if got is not None:
        row["scipy_max_diff"] = float(np.abs(got - reference).max())

    need = len(points) * (len(starts) + 4) * 8 * 2  # the distance matrix and its kernel values
    row["dense_bytes"] = need
    if need <= DENSE_LIMIT:
        t0 = time.perf_counter()
        got = dense_rbf(starts, targets, radius, p64)
        row["dense_ms"] = (time.perf_counter() - t0) * 1e3
        row["dense_max_diff"] = float(np.abs(got - reference).max())
    else:
        row["dense_ms"] = None
        row["dense_note"] = f"its (N, M) matrices need {need / 1e9:.0f} GB; not run (limit {DENSE_LIMIT / 1e9:.0f} GB)"
    return row


def many_figures(directory, k, runs):
    points = csrbf.read_mesh(directory / "100k.ply").vertices
    starts, targets, radius, kernel, poly = controls(directory / "100k.json")
    rng = np.random.default_rng(1)
    sets = targets + rng.normal(0, 0.05 * radius, (k, *starts.shape))
    out = np.empty((k, len(points), 3), dtype=np.float32)
    call = lambda: csrbf.deform_many(points, starts, sets, radius, kernel, poly, out=out)  # noqa: E731
    total = median_ms(call, runs)
    one = median_ms(lambda: csrbf.fit(starts, sets[0], radius, kernel, poly).deform(points), runs)
    return {"k": k, "vertices": len(points), "controls": len(starts), "total_ms": total,
            "per_variant_ms": total / k, "one_fit_deform_ms": one}


def rows_only(rows):
    """The Python-against-CLI table alone (--no-peers)."""
    print("\n| scene | csrbf bench fit + evaluate | Python fit + displacements | difference |")
    print("|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['cli_fit_evaluate_ms']:.1f} ms | {r['py_fit_evaluate_ms']:.1f} ms | "
              f"{100 * r['py_vs_cli']:+.0f} % |")


def main():
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("--scenes", nargs="+", default=["100k", "1m"])
    a.add_argument("--runs", type=int, default=5)
    a.add_argument("--variants", type=int, default=100)
    a.add_argument("--csrbf", default=str(ROOT / "target" / "release" / "csrbf"), help="the release binary")
    a.add_argument("--json", help="also write the figures here")
    a.add_argument("--peers", action=argparse.BooleanOptionalAction, default=True,
                   help="also time SciPy, the dense RBF and deform_many (--no-peers: Python against "
                        "`csrbf bench` alone, no SciPy needed)")
    args = a.parse_args()
    binary = Path(args.csrbf)
    if not binary.exists():
        sys.exit(f"{binary} is missing: cargo build --release -p csrbf-cli")
    cpu = platform.machine()
    if Path("/proc/cpuinfo").exists():
        cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                    if line.startswith("model name")), cpu)
    machine = f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, numpy {np.__version__}"
    print(f"# csrbf {csrbf.__version__} ({csrbf.build_profile} build), {machine}; medians of {args.runs}")
    if csrbf.build_profile != "release":
        print("# warning: this csrbf is a dev build (scripts/test.sh installs one), slower than users' "
              "release build: pip install crates/csrbf-py for the figures", file=sys.stderr)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        for name in args.scenes:
            subprocess.run([str(binary), "-q", "bench", "--scene", name, "--export", tmp], check=True)
            row = scene_figures(binary, directory, name, args.runs, args.peers)
            rows.append(row)
            print(json.dumps(row), flush=True)
        if not args.peers:
            rows_only(rows)
            return
        if "100k" not in args.scenes:
            subprocess.run([str(binary), "-q", "bench", "--scene", "100k", "--export", tmp], check=True)
        many = many_figures(directory, args.variants, max(1, args.runs // 2))
        print(json.dumps(many), flush=True)

    print("\n| scene | csrbf bench fit + evaluate | Python fit + displacements | difference | SciPy RBFInterpolator(neighbors=50) | dense (PyGeM-style) |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        dense = f"{r['dense_ms']:.0f} ms" if r["dense_ms"] is not None else r["dense_note"]
        scipy = f"{r['scipy_ms'] / 1e3:.1f} s" + ("" if r["scipy_note"].startswith("measured") else f" ({r['scipy_note']})")
        print(f"| {r['scene']} ({r['vertices']:,} / {r['controls']:,}) | {r['cli_fit_evaluate_ms']:.1f} ms | "
              f"{r['py_fit_evaluate_ms']:.1f} ms | {100 * r['py_vs_cli']:+.0f} % | {scipy} | {dense} |")
    print(f"\ndeform_many, K = {many['k']} on {many['vertices']:,} points / {many['controls']:,} controls: "
          f"{many['total_ms']:.0f} ms, {many['per_variant_ms']:.2f} ms per variant "
          f"(one fit + deform: {many['one_fit_deform_ms']:.1f} ms)")
    if args.json:
        Path(args.json).write_text(json.dumps({"machine": machine, "scenes": rows, "deform_many": many}, indent=1))


if __name__ == "__main__":
    main()
