"""The PyVista accessor: mesh.csrbf.deform(...) gives a new mesh, point data and faces kept."""

import numpy as np
import pytest

import pyvista as pv
import csrbf
import csrbf.pyvista  # noqa: F401  (registers the accessor)
from conftest import HEAD, SMILE, assert_close, diagonal


def test_deform_by_vectors_keeps_faces_and_point_data():
    sphere = pv.Sphere(radius=1.0)
    sphere.point_data["height"] = np.asarray(sphere.points)[:, 2].copy()
    starts = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    targets = starts + [[0.0, 0.0, 0.3], [0.0, 0.0, 0.0]]
    bent = sphere.csrbf.deform(starts, targets, radius=0.8, phase=1.0)
    assert isinstance(bent, pv.PolyData) and bent is not sphere
    assert np.array_equal(bent.faces, sphere.faces)
    assert np.array_equal(bent.point_data["height"], sphere.point_data["height"])
    expected = csrbf.fit(starts, targets, 0.8).deform(np.asarray(sphere.points))
    assert_close(bent.points, expected, 2.0)
    assert bent.points.dtype == sphere.points.dtype
    assert not np.array_equal(bent.points, sphere.points)  # the input is not changed
    assert np.allclose(sphere.points[:, 2].max(), 1.0, atol=1e-3)


def test_deform_by_a_control_file_equals_deform_mesh():
    head = csrbf.read_mesh(HEAD)
    cells = np.hstack([np.full((len(head.triangles), 1), 3), head.triangles]).astype(np.int64)
    poly = pv.PolyData(head.vertices, cells.ravel())
    smiled, report = poly.csrbf.deform(str(SMILE), phase=0.7, return_report=True)
    out, expected = csrbf.deform_mesh(head, SMILE, phase=0.7)
    assert_close(smiled.points, out.vertices, diagonal(head.vertices))
    assert report.moved == expected.moved
    assert smiled.n_cells == poly.n_cells


def test_quads_and_other_datasets():
    plane = pv.Plane(i_resolution=8, j_resolution=8)  # quads
    starts, targets, radius, _, _ = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 0.2]]), 0.4, 0, 0
    moved = plane.csrbf.deform({"radius": radius, "controls": [{"from": [0, 0, 0], "to": [0, 0, 0.2]}]})
    assert moved.points[:, 2].max() == pytest.approx(0.2, abs=1e-3)
    grid = pv.ImageData(dimensions=(4, 4, 4)).cast_to_unstructured_grid()
    warped = grid.csrbf.deform(starts + 1.5, targets + 1.5, radius=1.0)
    assert isinstance(warped, pv.UnstructuredGrid) and warped.n_cells == grid.n_cells
    with pytest.raises(TypeError, match="PolyData"):
        grid.csrbf.deform(str(SMILE))
    with pytest.raises(TypeError, match="radius= is required"):
        plane.csrbf.deform(starts, targets)


@pytest.mark.parametrize("kind", ["ImageData", "RectilinearGrid"])
def test_grids_with_implicit_points_come_back_as_structured_grids(kind):
    """Issue 41: an ImageData's points are its origin and spacing, which no
    deformation keeps; it comes back as the StructuredGrid of the same
    points and cells, its data kept, moved as an UnstructuredGrid is."""
    grid = (pv.ImageData(dimensions=(5, 4, 3), spacing=(0.5, 0.5, 0.5)) if kind == "ImageData"
            else pv.RectilinearGrid(np.linspace(0, 2, 5), np.linspace(0, 1.5, 4), np.linspace(0, 1, 3)))
    grid.point_data["t"] = np.arange(grid.n_points, dtype=float)
    grid.cell_data["c"] = np.arange(grid.n_cells, dtype=float)
    starts, targets = np.array([[1.0, 0.5, 0.5]]), np.array([[1.0, 0.5, 0.8]])
    warped = grid.csrbf.deform(starts, targets, radius=1.0)
    assert isinstance(warped, pv.StructuredGrid) and warped.dimensions == grid.dimensions
    assert warped.n_cells == grid.n_cells
    assert np.array_equal(warped.point_data["t"], grid.point_data["t"])
    assert np.array_equal(warped.cell_data["c"], grid.cell_data["c"])
    want = grid.cast_to_unstructured_grid().csrbf.deform(starts, targets, radius=1.0)
    assert np.array_equal(warped.points, want.points)
    assert np.abs(warped.points - grid.points).max() == pytest.approx(0.3, abs=1e-6)
    assert type(grid).__name__ == kind  # the input is not changed
