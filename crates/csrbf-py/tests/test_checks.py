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


def test_control_dicts_take_numpy_values():
    """A radius computed with numpy and starts taken from a mesh's vertices
    are what a script has at hand: the dict takes them as the numbers they
    are, and the result equals the one from plain floats and lists."""
    mesh = csrbf.read_mesh(HEAD)
    plain_out, _ = csrbf.deform_mesh(mesh, PULL)
    c = PULL["controls"][0]
    numpy_dict = {
        "radius": np.float32(PULL["radius"]),
        "controls": [{"from": np.array(c["from"]), "to": np.array(c["to"], dtype=np.float32)}],
    }
    out, _ = csrbf.deform_mesh(mesh, numpy_dict)
    np.testing.assert_allclose(out.vertices, plain_out.vertices, atol=1e-5)
    with pytest.raises(TypeError, match="a value of type object cannot be part of a control file"):
        csrbf.deform_mesh(mesh, {"radius": object(), "controls": []})


def test_a_vertex_that_is_not_finite_is_refused_by_name():
    """deform_mesh judges folds and moves of every face: a NaN vertex would
    make its figures false, so it is refused, naming the vertex."""
    mesh = csrbf.read_mesh(HEAD)
    v = mesh.vertices.copy()
    v[7] = [np.nan, 0.0, 1.0]
    bad = csrbf.Mesh(v, mesh.triangles)
    with pytest.raises(ValueError, match=r"mesh: vertex 7 has a coordinate that is not finite"):
        csrbf.deform_mesh(bad, PULL)
