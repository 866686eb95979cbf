"""Shared fixtures: the bundled models, the csrbf binary, a CLI runner."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
ASSETS = ROOT / "assets"
MODELS = ASSETS / "models"
SMILE = ASSETS / "controls" / "head_smile.json"
HEAD = MODELS / "cgal_head.off"


@pytest.fixture(scope="session")
def csrbf_bin():
    """The `csrbf` binary: $CSRBF_BIN, else target/debug/csrbf, built when missing."""
    path = Path(os.environ.get("CSRBF_BIN", ROOT / "target" / "debug" / "csrbf"))
    if not path.exists():
        subprocess.run(["cargo", "build", "-q", "-p", "csrbf-cli"], cwd=ROOT, check=True)
        path = ROOT / "target" / "debug" / "csrbf"
    return path


@pytest.fixture
def cli(csrbf_bin):
    """Runs `csrbf ARGS...` quietly; returns its parsed --json output, or None."""

    def run(*args):
        done = subprocess.run([str(csrbf_bin), "-q", *map(str, args)], capture_output=True, text=True)
        assert done.returncode == 0, f"csrbf {' '.join(map(str, args))} failed:\n{done.stderr}"
        return json.loads(done.stdout) if "--json" in args else None

    return run


def controls_of(path):
    """(starts, targets, radius, kernel, polynomial) of a one-deformation control file."""
    spec = json.loads(Path(path).read_text())
    starts = np.array([c["from"] for c in spec["controls"]], dtype=np.float64)
    targets = np.array([c["to"] for c in spec["controls"]], dtype=np.float64)
    return starts, targets, spec["radius"], spec.get("kernel", "c2"), spec.get("polynomial", "none")


def diagonal(points):
    points = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def assert_close(a, b, scale, tol=1e-6):
    """Equal within tol of scale (a bounding-box diagonal), saying by how much when not."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    assert a.shape == b.shape, f"shapes {a.shape} and {b.shape}"
    worst = float(np.max(np.abs(a - b))) if a.size else 0.0
    assert worst <= tol * scale, f"differ by {worst:.3e}, more than {tol} of {scale:.4g}"
