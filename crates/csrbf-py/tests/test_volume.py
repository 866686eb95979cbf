"""Volume meshes from Python (issue 43): read_mesh of .vtk/.vtu/.msh gives a
VolumeMesh with cells and zones; files Gmsh and meshio write read right,
what csrbf writes meshio reads; morph_volume's cell check."""

import gmsh  # tests/requirements.txt: a missing one fails, it does not skip
import meshio
import numpy as np
import pytest

import csrbf
from conftest import ASSETS

SAMPLE = ASSETS / "volume" / "sphere_in_box.msh"


def test_read_mesh_gives_cells_and_zones():
    vm = csrbf.read_mesh(SAMPLE)
    assert isinstance(vm, csrbf.VolumeMesh)
    assert vm.points.dtype == np.float64
    assert vm.cells_dict["tetra"].shape == (2898, 4)
    assert vm.zones == {"outer": (1, 2), "inner": (2, 2), "fluid": (3, 3)}
    assert len(vm.cell_zones) == len(vm)
    assert set(np.unique(vm.cell_zones)) == {1, 2, 3}
    info = vm.info()
    assert info["inverted_or_flat"] == 0 and info["min_scaled_jacobian"] > 0
    surface = vm.boundary()
    assert isinstance(surface, csrbf.Mesh)


def gmsh_box(path, version, binary):
    """A box around a sphere meshed and written by Gmsh itself."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("t")
        box = gmsh.model.occ.addBox(-1, -1, -1, 2, 2, 2)
        ball = gmsh.model.occ.addSphere(0, 0, 0, 0.4)
        cut, _ = gmsh.model.occ.cut([(3, box)], [(3, ball)])
        gmsh.model.occ.synchronize()
        faces = [t for _, t in gmsh.model.getEntities(2)]
        inner = [f for f in faces if gmsh.model.getType(2, f) == "Sphere"]
        gmsh.model.addPhysicalGroup(2, [f for f in faces if f not in inner], 11, "outer")
        gmsh.model.addPhysicalGroup(2, inner, 12, "inner")
        gmsh.model.addPhysicalGroup(3, [cut[0][1]], 13, "fluid")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(3)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.option.setNumber("Mesh.Binary", 1 if binary else 0)
        gmsh.write(str(path))
        _, coords, _ = gmsh.model.mesh.getNodes()
        types, tags, _ = gmsh.model.mesh.getElements(3)
        return coords.reshape(-1, 3), sum(len(t) for t in tags)
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("version", [2.2, 4.1])
@pytest.mark.parametrize("binary", [False, True])
def test_files_gmsh_writes_read_right(tmp_path, version, binary):
    path = tmp_path / f"box_{version}_{int(binary)}.msh"
    coords, tets = gmsh_box(path, version, binary)
    vm = csrbf.read_mesh(path)
    assert vm.cells_dict["tetra"].shape == (tets, 4)
    assert vm.zones == {"outer": (11, 2), "inner": (12, 2), "fluid": (13, 3)}
    # Every node Gmsh made, in some order (Gmsh numbers them by entity).
    got = np.unique(np.round(vm.points, 12), axis=0)
    want = np.unique(np.round(coords, 12), axis=0)
    assert got.shape == want.shape and np.array_equal(got, want)
    assert vm.info()["inverted_or_flat"] == 0
    # meshio reads the same file to the same cells.
    m = meshio.read(path)
    assert np.array_equal(m.points, vm.points)
    tet = np.concatenate([b.data for b in m.cells if b.type == "tetra"])
    assert np.array_equal(tet, vm.cells_dict["tetra"])


@pytest.mark.parametrize("ext", ["vtu", "vtk", "msh"])
def test_meshio_reads_what_csrbf_writes(tmp_path, ext):
    vm = csrbf.read_mesh(SAMPLE)
    out = tmp_path / f"box.{ext}"
    csrbf.write_mesh(vm, out)
    m = meshio.read(out)
    assert np.array_equal(m.points, vm.points)
    back = csrbf.from_meshio(m)
    for kind, cells in vm.cells_dict.items():
        assert np.array_equal(back.cells_dict[kind], cells), kind
    assert np.array_equal(back.cell_zones, vm.cell_zones)
    if ext == "vtk":
        # meshio 5.3 does not read a legacy file's dataset FIELD data (csrbf
        # writes the names there and reads them back itself: below).
        assert sorted(t for t, _ in back.zones.values()) == [1, 2, 3]
        assert csrbf.read_mesh(out).zones == vm.zones
    else:
        assert back.zones == vm.zones


MESHIO_WRITES = [
    ("vtu", {"binary": True}),  # base64, zlib (meshio's default)
    ("vtu", {"binary": False}),
    ("vtk", {"binary": True}),  # VTK 5.1 legacy, vtktypeint64 arrays
    ("vtk", {"binary": False}),
    ("msh", {"file_format": "gmsh22", "binary": False}),
    ("msh", {"file_format": "gmsh22", "binary": True}),
    # meshio 5.3 writes Gmsh 4.1 only with its own entity data; Gmsh itself
    # writes the 4.1 files read above.
]


@pytest.mark.parametrize("ext,kwargs", MESHIO_WRITES)
def test_csrbf_reads_what_meshio_writes(tmp_path, ext, kwargs):
    vm = csrbf.read_mesh(SAMPLE)
    m = csrbf.to_meshio(vm)
    if ext == "msh":
        # meshio's Gmsh writer wants the geometrical tag too.
        m.cell_data["gmsh:geometrical"] = m.cell_data["gmsh:physical"]
    out = tmp_path / f"x.{ext}"
    meshio.write(out, m, **kwargs)
    back = csrbf.read_mesh(out)
    if kwargs["binary"]:
        assert np.array_equal(back.points, vm.points)
    else:
        # meshio prints ASCII coordinates to 12 digits or so.
        assert np.allclose(back.points, vm.points, rtol=0, atol=1e-10)
    assert np.array_equal(back.cells_dict["tetra"], vm.cells_dict["tetra"])
    assert np.array_equal(back.cells_dict["triangle"], vm.cells_dict["triangle"])
    assert np.array_equal(back.cell_zones, vm.cell_zones)
    if ext == "msh":
        assert back.zones == vm.zones
    else:
        # meshio writes no field data to VTK files: the tags, unnamed.
        assert back.zones == {f"zone {t}": (t, d) for (t, d) in vm.zones.values()}


def test_morph_volume_checks_every_cell():
    vm = csrbf.read_mesh(SAMPLE)
    gentle = {"boundary": {"radius": 1.2, "move": [{"zone": "inner", "translate": [0.15, 0, 0]}], "hold": ["outer"]}}
    moved, report = csrbf.morph_volume(vm, gentle)
    assert report.inverted_cells == 0 and report.first_inversion is None
    held = vm.zone_nodes("outer")
    assert np.array_equal(moved.points[held], vm.points[held])
    inner = vm.zone_nodes("inner")
    assert np.allclose(moved.points[inner], vm.points[inner] + [0.15, 0, 0], atol=1e-12)
    assert report.to_dict()["cells"]["zones"][0]["name"] == "fluid"
    push = {"boundary": {"radius": 0.45, "move": [{"zone": "inner", "translate": [0.5, 0, 0]}], "hold": ["outer"]}}
    _, folded = csrbf.morph_volume(vm, push)
    assert folded.inverted_cells > 0 and 0 < folded.first_inversion < 1
    assert "inside out" in folded.advice
    # The count is the reference's: signed volumes of the moved tetrahedra.
    moved, _ = csrbf.morph_volume(vm, push)
    p = moved.points[moved.cells_dict["tetra"]]
    vol = np.einsum("ij,ij->i", p[:, 3] - p[:, 0], np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
    assert folded.inverted_cells == int((vol <= 0).sum())
    # A control file works too, and phase 0 leaves every node.
    controls = {"radius": 0.6, "controls": [{"from": [0.4, 0, 0], "to": [0.45, 0, 0]}]}
    rest, r0 = csrbf.morph_volume(vm, controls, phase=0.0)
    assert np.array_equal(rest.points, vm.points) and r0.moved == 0


def test_bad_volume_input_is_refused_by_name(tmp_path):
    vm = csrbf.read_mesh(SAMPLE)
    with pytest.raises(csrbf.Error, match="no zone \"wing\""):
        csrbf.morph_volume(vm, {"boundary": {"radius": 1, "move": [{"zone": "wing", "translate": [1, 0, 0]}]}})
    with pytest.raises(csrbf.Error, match="boundary.radius"):
        csrbf.morph_volume(vm, {"boundary": {"move": [{"zone": "inner", "translate": [1, 0, 0]}]}})
    with pytest.raises(csrbf.Error, match=r"a VolumeMesh is written as one of"):
        csrbf.write_mesh(vm, tmp_path / "x.ply")
    cut = tmp_path / "cut.msh"
    cut.write_bytes(SAMPLE.read_bytes()[:5000])
    with pytest.raises(csrbf.Error, match="cut.msh"):
        csrbf.read_mesh(cut)
    with pytest.raises(ValueError, match="names node"):
        csrbf.VolumeMesh(np.zeros((3, 3)), [("tetra", [[0, 1, 2, 3]])])
    with pytest.raises(ValueError, match="unknown cell kind"):
        csrbf.VolumeMesh(np.zeros((4, 3)), [("tet10", [[0, 1, 2, 3]])])
