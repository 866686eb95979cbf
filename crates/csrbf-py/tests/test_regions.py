"""Regions that follow the surface (issue 23), through `deform_mesh` with a dict."""

import numpy as np
import pytest

import csrbf


def hairpin(gap=0.2, step=0.05, legs=40, rows=10):
    """An arm beside a torso: a strip bent into a hairpin (torso leg at x = 0,
    arm leg at x = gap), near in space across the gap, far along the surface.
    Returns the Mesh and a mask of the torso leg's vertices."""
    path = [(0.0, -k * step) for k in range(legs, -1, -1)]
    arc = 6
    for k in range(1, arc):
        a = np.pi * (1 - k / arc)
        path.append((gap / 2 * (1 + np.cos(a)), gap / 2 * np.sin(a)))
    path += [(gap, -k * step) for k in range(legs + 1)]
    vertices = np.array([(x, y, j / rows) for x, y in path for j in range(rows + 1)], dtype=np.float32)
    at = lambda i, j: i * (rows + 1) + j  # noqa: E731
    tris = []
    for i in range(len(path) - 1):
        for j in range(rows):
            tris += [(at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1))]
    torso = (vertices[:, 0] < gap / 2) & (vertices[:, 1] < 0)
    return csrbf.Mesh(vertices, np.array(tris, dtype=np.uint32)), torso


def pull(region=None):
    spec = {
        "radius": 0.6,
        "controls": [
            {"from": [0.2, -1.5, 0.5], "to": [0.3, -1.5, 0.5]},
            {"from": [0.2, -1.0, 0.5], "to": [0.2, -1.0, 0.5]},
        ],
    }
    if region is not None:
        spec["region"] = region
    return spec


def test_a_connected_region_leaves_the_torso_beside_the_arm_alone():
    mesh, torso = hairpin()
    spatial, _ = csrbf.deform_mesh(mesh, pull())
    moved = np.linalg.norm(spatial.vertices - mesh.vertices, axis=1)
    assert (moved[torso] > 0).sum() > 50  # the space map reaches across the gap
    out, report = csrbf.deform_mesh(mesh, pull({"connected": {"distance": 0.5, "from": "starts"}, "falloff": 0.3}))
    moved = np.linalg.norm(out.vertices - mesh.vertices, axis=1)
    assert (moved[torso] > 0).sum() == 0
    assert moved.max() == pytest.approx(0.1, abs=1e-4)
    assert report.inside_out_faces == 0


def test_bad_connected_regions_name_their_key():
    mesh, _ = hairpin()
    for region, key in [
        ({"connected": {"distance": -1}}, "region.connected.distance"),
        ({"connected": {"distance": 1, "from": "elbow"}}, "region.connected.from"),
    ]:
        with pytest.raises(csrbf.Error, match=key.replace(".", r"\.")):
            csrbf.deform_mesh(mesh, pull(region))
    # A point cloud has no surface to follow.
    cloud = csrbf.Mesh(np.eye(3, dtype=np.float32))
    with pytest.raises(csrbf.Error, match="needs a mesh with faces"):
        csrbf.deform_mesh(cloud, pull({"connected": {"distance": 1}}))
