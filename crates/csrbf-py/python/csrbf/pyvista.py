"""PyVista meshes deformed by csrbf: ``import csrbf.pyvista`` registers the
``csrbf`` accessor on every PyVista dataset (pyvista >= 0.48).

>>> import pyvista as pv, csrbf.pyvista
>>> sphere = pv.Sphere()
>>> bent = sphere.csrbf.deform(starts, targets, radius=0.2, phase=1.0)
>>> smiled = head.csrbf.deform("smile.json")          # a control file
>>> smiled, report = head.csrbf.deform("smile.json", return_report=True)

The result is a new dataset of the same kind (a deep copy: point data, cell
data and faces kept) with moved points; the input is not changed. Grids
whose points are implicit (``ImageData``, ``RectilinearGrid``: an origin and
spacings, which no deformation keeps) come back as the ``StructuredGrid``
of the same points and cells, data kept. No rendering is involved, so it
works without a display.
"""

from __future__ import annotations

import numpy as np
import pyvista as pv

from . import Mesh, deform_mesh, fit

__all__ = ["CsrbfAccessor"]


def _mesh_of(poly: pv.PolyData) -> Mesh:
    """A csrbf Mesh with the polygon faces of a PolyData (for control files:
    regions, handles and the turned-over face check need the faces)."""
    points = np.asarray(poly.points)
    if len(poly.faces) == 0:
        return Mesh(points)
    if poly.is_all_triangles:
        return Mesh(points, np.asarray(poly.regular_faces))
    cells = np.asarray(poly.faces)
    faces, i = [], 0
    while i < len(cells):
        n = int(cells[i])
        faces.append(cells[i + 1 : i + 1 + n])
        i += n + 1
    return Mesh(points, faces=faces)


def _movable_copy(dataset: pv.DataSet) -> pv.DataSet:
    """A deep copy of `dataset` whose points can be set: the StructuredGrid
    of a grid whose points are implicit (ImageData, RectilinearGrid)."""
    if isinstance(dataset, (pv.ImageData, pv.RectilinearGrid)):
        return dataset.cast_to_structured_grid()
    out = dataset.copy(deep=True)
    if not hasattr(out, "points") or isinstance(out, pv.MultiBlock):
        raise TypeError(
            f"csrbf deforms datasets with points (PolyData, UnstructuredGrid, StructuredGrid, "
            f"ImageData and RectilinearGrid as a StructuredGrid), not {type(dataset).__name__}"
        )
    return out


@pv.register_dataset_accessor("csrbf", pv.DataSet)
class CsrbfAccessor:
    """``dataset.csrbf``: csrbf deformations of a PyVista dataset."""

    def __init__(self, dataset: pv.DataSet):
        self._dataset = dataset

    def deform(
        self,
        starts_or_controls,
        targets=None,
        *,
        radius: float | None = None,
        kernel: str = "c2",
        polynomial: str = "none",
        phase: float = 1.0,
        return_report: bool = False,
    ):
        """A copy of the dataset with its points deformed.

        Either ``deform(starts, targets, radius=R, kernel=..., polynomial=...,
        phase=...)`` with (M, 3) arrays, as ``csrbf.fit``, or
        ``deform(controls, phase=...)`` with a control file (a path, or a dict
        in the file's form), as ``csrbf.deform_mesh`` (PolyData only: regions,
        handles and the turned-over face check need its faces). With
        ``return_report=True`` the control-file form returns
        ``(dataset, csrbf.Report)``. An ImageData or a RectilinearGrid
        comes back as a StructuredGrid (its points are no longer a grid).
        """
        out = _movable_copy(self._dataset)
        points = np.asarray(self._dataset.points)
        if targets is None:
            if radius is not None:
                raise TypeError("a control file gives its own radius; pass radius= only with starts and targets")
            if not isinstance(self._dataset, pv.PolyData):
                raise TypeError(
                    f"a control file needs a PolyData (faces), got {type(self._dataset).__name__}; "
                    "pass starts and targets instead"
                )
            moved, report = deform_mesh(_mesh_of(self._dataset), starts_or_controls, phase)
            out.points = moved.vertices.astype(points.dtype, copy=False)
            return (out, report) if return_report else out
        if radius is None:
            raise TypeError("radius= is required with starts and targets (a share of the model's size)")
        d = fit(starts_or_controls, targets, radius, kernel=kernel, polynomial=polynomial)
        out.points = d.deform(points, phase)
        return (out, None) if return_report else out
