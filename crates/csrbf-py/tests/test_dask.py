"""examples/python/augment_dask.py on a LocalCluster of two workers."""

import importlib.util
import subprocess
import sys

import numpy as np

import csrbf
from conftest import MODELS, ROOT

EXAMPLE = ROOT / "examples" / "python" / "augment_dask.py"


def load_example():
    spec = importlib.util.spec_from_file_location("augment_dask", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_dask_example_augments_a_folder_on_two_workers(tmp_path):
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    for name in ("cgal_head.off", "pybullet_duck.obj", "assimp_sphereWithHole.stl"):
        (meshes / name).write_bytes((MODELS / name).read_bytes())
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, str(EXAMPLE), str(meshes), "--out", str(out), "--variants", "3", "--workers", "2"],
        capture_output=True, text=True, timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "3/3 meshes" in done.stderr  # the progress bar
    assert "9 meshes written" in done.stdout
    written = sorted(p.name for p in out.iterdir() if p.suffix != ".mtl")
    assert len(written) == 9 and "cgal_head_v002.off" in written and "assimp_sphereWithHole_v000.ply" in written
    # An OBJ with materials gets its material library beside it (issue 24).
    assert all((out / f"pybullet_duck_v{k:03d}.mtl").exists() for k in range(3))

    # Each variant is the deformation the example's seeded edits describe.
    example = load_example()
    head = csrbf.read_mesh(meshes / "cgal_head.off")
    starts, targets, radius = example.edits(head.vertices, 3, 16, 0.1, example.seed_of(meshes / "cgal_head.off", 0))
    for k in range(3):
        expected = csrbf.fit(starts, targets[k], radius).deform(head.vertices)
        got = csrbf.read_mesh(out / f"cgal_head_v{k:03d}.off").vertices
        assert np.abs(got - expected).max() <= 1e-5 * head.diagonal
        assert not np.array_equal(got, head.vertices)
