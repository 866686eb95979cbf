"""What deform_mesh checks beyond moves and folds (issue 23): stretched faces."""

import numpy as np
import pytest

import csrbf
from conftest import HEAD

PULL = {"radius": 3, "controls": [{"from": [2.15, 10.18, 4.42], "to": [2.15, 10.18, 12.0]}]}


def stretch_of(rest, moved, tris):
    """The reference: largest singular value of each triangle's
    rest-to-deformed map in its plane, from numpy's SVD."""
    out = []
    for t in tris:
        r, m = rest[t].astype(np.float64), moved[t].astype(np.float64)
        e = np.stack([r[1] - r[0], r[2] - r[0]], axis=1)
        f = np.stack([m[1] - m[0], m[2] - m[0]], axis=1)
        q, rr = np.linalg.qr(e)
        out.append(np.linalg.svd(f @ np.linalg.inv(rr), compute_uv=False)[0])
    return np.array(out)


def test_stretched_faces_match_a_numpy_reference():
    mesh = csrbf.read_mesh(HEAD)
    out, report = csrbf.deform_mesh(mesh, PULL, stretch_limit=2.0)
    ref = stretch_of(mesh.vertices, out.vertices, mesh.triangles)
    assert report.largest_stretch == pytest.approx(ref.max(), rel=1e-4)
    assert report.stretch_limit == 2.0
    np.testing.assert_array_equal(report.stretched, np.flatnonzero(ref > 2.0 * (1 + 1e-9)))
    assert report.stretched.dtype == np.uint32
    assert report.stretched_faces == len(report.stretched) > 0
    assert "stretched" in report.warning_kinds
    d = report.to_dict()
    assert d["stretched_faces"] == report.stretched_faces and d["largest_stretch"] == report.largest_stretch
    assert "largest stretch" in repr(report)
    # The default limit is 4.
    _, four = csrbf.deform_mesh(mesh, PULL)
    assert four.stretch_limit == 4.0 and four.stretched_faces < report.stretched_faces


def test_a_bad_stretch_limit_is_named():
    mesh = csrbf.read_mesh(HEAD)
    for bad in [0.5, float("nan"), float("inf")]:
        with pytest.raises(ValueError, match="stretch_limit"):
            csrbf.deform_mesh(mesh, PULL, stretch_limit=bad)


def test_faces_pushed_through_each_other_are_reported():
    from test_regions import hairpin

    mesh, _ = hairpin()
    push = {"radius": 0.5, "controls": [{"from": [0.2, -1.5, 0.5], "to": [-0.15, -1.5, 0.5]}]}
    _, report = csrbf.deform_mesh(mesh, push)
    pairs = report.self_intersections
    assert pairs is not None and pairs.dtype == np.uint32 and pairs.shape[1] == 2 and len(pairs) > 0
    assert (pairs[:, 0] < pairs[:, 1]).all()
    assert "self_intersecting" in report.warning_kinds
    assert report.to_dict()["self_intersections"] == len(pairs)
    _, off = csrbf.deform_mesh(mesh, push, self_intersections=False)
    assert off.self_intersections is None
    _, small = csrbf.deform_mesh(mesh, {**push, "controls": [{"from": [0.2, -1.5, 0.5], "to": [0.25, -1.5, 0.5]}]})
    assert small.self_intersections.shape == (0, 2)
