"""csrbf's exports opened by the programs users open them in (issue 24):
Blender's own glTF, OBJ, PLY and STL importers, headless (the bpy module),
and trimesh (blender/requirements.txt installs it with Pillow). Every file is made here by the `csrbf`
binary (CSRBF_BIN, else target/debug/csrbf, built when missing)."""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import bpy
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "assets" / "models"


def csrbf_bin() -> Path:
    given = os.environ.get("CSRBF_BIN")
    if given:
        return Path(given)
    built = ROOT / "target" / "debug" / "csrbf"
    if not built.exists():
        subprocess.run(["cargo", "build", "-q", "-p", "csrbf-cli"], cwd=ROOT, check=True)
    return built


def csrbf(*args) -> str:
    r = subprocess.run([str(csrbf_bin()), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, f"csrbf {' '.join(map(str, args))}: {r.stderr}"
    return r.stderr


def khronos_validates(path: Path):
    """The Khronos glTF validator (scripts/setup.sh installs it) finds no error."""
    r = subprocess.run(["node", str(ROOT / "scripts" / "validate_gltf.mjs"), str(path)], capture_output=True, text=True)
    assert r.returncode == 0 and ": 0 errors" in r.stdout, r.stdout + r.stderr


def glb_json(path: Path) -> dict:
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20 : 20 + length])


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def import_gltf(path: Path):
    fresh()
    bpy.ops.import_scene.gltf(filepath=str(path))
    return bpy.context.scene


def meshes():
    return [o for o in bpy.context.scene.objects if o.type == "MESH"]


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("demos")
    csrbf("demo", "-q", "all", "--out", out / "d", "--size", "32x24", "--gif")
    return out


def checker(path: Path, w=8, h=4) -> np.ndarray:
    """A PNG whose every pixel differs from its mirror images; its RGBA
    floats, bottom row first (as Blender keeps them)."""
    img = bpy.data.images.new("checker", w, h, alpha=True)
    px = np.zeros((h, w, 4), np.float32)
    px[..., 0] = np.arange(w)[None, :] / (w - 1)
    px[..., 1] = np.arange(h)[:, None] / (h - 1)
    px[..., 2] = 0.25
    px[..., 3] = 1.0
    img.pixels.foreach_set(px.ravel())
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    return px


def test_a_texture_on_the_duck_with_uv_seams_arrives(demos, tmp_path):
    """Item 1: the duck has UV seams; its texture was dropped from export."""
    fish = demos / "d" / "fish"
    fresh()
    want = checker(fish / "checker.png")
    scene_file = fish / "fish.scene.json"
    scene = json.loads(scene_file.read_text())
    scene["objects"][0]["parts"][0]["texture"] = "checker.png"
    scene_file.write_text(json.dumps(scene))
    glb = tmp_path / "duck.glb"
    csrbf("export", "-q", scene_file, "--out", glb)
    doc = glb_json(glb)
    written = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]["count"]
    assert written > 2108  # split at the seams
    khronos_validates(glb)

    import_gltf(glb)
    (duck,) = meshes()
    me = duck.data
    assert len(me.vertices) == written
    assert len(me.uv_layers) == 1
    uv = np.zeros(2 * len(me.loops), np.float32)
    me.uv_layers[0].data.foreach_get("uv", uv)
    assert uv.min() >= -1e-6 and uv.max() <= 1 + 1e-6 and np.ptp(uv) > 0.5
    # The material's base colour comes from the image, pixel for pixel.
    mat = me.materials[0]
    images = [n.image for n in mat.node_tree.nodes if n.type == "TEX_IMAGE"]
    assert len(images) == 1 and images[0] is not None
    got = np.zeros(len(images[0].pixels), np.float32)
    images[0].pixels.foreach_get(got)
    assert images[0].size[:] == (want.shape[1], want.shape[0])
    assert np.abs(got - want.ravel()).max() <= 1.0 / 255 + 1e-6
    # Item 5: shape keys named after the control files' stems.
    assert [k.name for k in me.shape_keys.key_blocks] == ["Basis", "beak", "tail", "wings"]


@pytest.mark.parametrize("demo", ["face", "fish", "ball", "brick"])
def test_every_demo_imports_with_its_shape_keys_camera_and_lights(demos, tmp_path, demo):
    glb = tmp_path / f"{demo}.glb"
    csrbf("export", "-q", demos / "d" / demo / f"{demo}.scene.json", "--out", glb)
    doc = glb_json(glb)
    # trimesh reads every mesh with the vertices the file holds.
    import trimesh

    scene = trimesh.load(glb, process=False)
    counts = sorted(len(g.vertices) for g in scene.geometry.values())
    want = sorted(sum(doc["accessors"][p["attributes"]["POSITION"]]["count"] for p in m["primitives"]) for m in doc["meshes"])
    assert counts == want, (counts, want)
    import_gltf(glb)
    objs = meshes()
    assert len(objs) == len(doc["meshes"])
    for obj, mesh in zip(sorted(objs, key=lambda o: o.name), sorted(doc["meshes"], key=lambda m: m["name"])):
        names = mesh.get("extras", {}).get("targetNames", [])
        keys = obj.data.shape_keys
        got = [] if keys is None else [k.name for k in keys.key_blocks][1:]
        assert got == names, (obj.name, got, names)
        assert all(len(n.encode()) <= 63 for n in names)
    # Item 6: the scene's camera, set as Blender's scene camera, and its lights.
    cams = [o for o in bpy.context.scene.objects if o.type == "CAMERA"]
    lights = [o for o in bpy.context.scene.objects if o.type == "LIGHT"]
    assert len(cams) == 1 and len(lights) >= 1
    assert all(l.data.type == "SUN" for l in lights)
    x, y, z = doc["nodes"][[n.get("camera") for n in doc["nodes"]].index(0)]["translation"]
    # Blender is Z-up: glTF's (x, y, z) is its (x, -z, y).
    assert np.allclose(cams[0].matrix_world.translation[:], (x, -z, y), atol=1e-4)
    # Item 4: the ball's see-through box.
    if demo == "ball":
        box = next(o for o in objs if o.name.startswith("box"))
        assert box.data.materials[0].surface_render_method == "BLENDED" or box.data.materials[0].blend_method == "BLEND"


def test_a_deformed_obj_names_a_material_library_that_is_there(tmp_path):
    """Item 3: the deformed duck's OBJ named duck.mtl, which was nowhere."""
    controls = tmp_path / "c.json"
    controls.write_text(json.dumps({"radius": 0.3, "controls": [{"from": [0, 0.3, 0], "to": [0, 0.35, 0]}]}))
    out = tmp_path / "out" / "duck_smile.obj"
    out.parent.mkdir()
    csrbf("deform", "-q", "--mesh", MODELS / "pybullet_duck.obj", "--controls", controls, "--out", out)
    lib = next(l.split(" ", 1)[1] for l in out.read_text().splitlines() if l.startswith("mtllib "))
    assert (out.parent / lib).is_file()
    fresh()
    bpy.ops.wm.obj_import(filepath=str(out))
    (duck,) = meshes()
    assert [m.name for m in duck.data.materials] == ["blinn3"]


def test_a_ply_keeps_its_uvs_in_blender(tmp_path):
    """Item 2: PLY UVs were written as `u v`, which Blender does not read as UVs."""
    controls = tmp_path / "c.json"
    controls.write_text(json.dumps({"radius": 0.5, "controls": [{"from": [0.5, 0.5, 0.5], "to": [0.5, 0.55, 0.5]}]}))
    out = tmp_path / "box.ply"
    csrbf("deform", "-q", "--mesh", MODELS / "assimp_BoxTextured.glb", "--controls", controls, "--out", out)
    fresh()
    bpy.ops.wm.ply_import(filepath=str(out))
    (box,) = meshes()
    assert len(box.data.uv_layers) == 1
    uv = np.zeros(2 * len(box.data.loops), np.float32)
    box.data.uv_layers[0].data.foreach_get("uv", uv)
    assert np.ptp(uv) > 0.5


def test_trimesh_reads_the_textured_export(demos, tmp_path):
    import trimesh

    import PIL  # noqa: F401  (trimesh decodes images with Pillow)

    glb = tmp_path / "box.glb"
    shutil.copy(MODELS / "assimp_BoxTextured.glb", tmp_path / "in.glb")
    controls = tmp_path / "c.json"
    controls.write_text(json.dumps({"radius": 0.5, "controls": [{"from": [0.5, 0.5, 0.5], "to": [0.5, 0.55, 0.5]}]}))
    csrbf("deform", "-q", "--mesh", tmp_path / "in.glb", "--controls", controls, "--out", glb)
    scene = trimesh.load(glb)
    (geom,) = scene.geometry.values()
    assert geom.visual.uv is not None and len(geom.visual.uv) == len(geom.vertices)
    assert geom.visual.material.baseColorTexture is not None


def test_the_timeline_fits_when_imported_at_the_scenes_rate(demos, tmp_path):
    """Item 7: glTF has no frame rate; the scene's is in the extras, and
    with Blender's rate set to it first the keys land on whole frames."""
    glb = tmp_path / "fish.glb"
    csrbf("export", "-q", demos / "d" / "fish" / "fish.scene.json", "--out", glb)
    timing = glb_json(glb)["asset"]["extras"]
    fresh()
    bpy.context.scene.render.fps = int(timing["fps"])
    bpy.ops.import_scene.gltf(filepath=str(glb), import_scene_extras=True)
    scene = bpy.context.scene
    assert scene["fps"] == timing["fps"] and scene["duration"] == timing["duration"]
    (action,) = bpy.data.actions
    assert tuple(action.frame_range) == (0.0, timing["duration"] * timing["fps"])
    # The camera looks where the scene's does.
    (cam,) = [o for o in scene.objects if o.type == "CAMERA"]
    scene_file = json.loads((demos / "d" / "fish" / "fish.scene.json").read_text())["camera"]
    look = np.subtract(scene_file["target"], scene_file["eye"])
    look = np.array([look[0], -look[2], look[1]]) / np.linalg.norm(look)
    forward = -np.array(cam.matrix_world.to_3x3().col[2][:])
    assert np.allclose(forward, look, atol=1e-5)


def accessor(path: Path, doc: dict, index: int) -> np.ndarray:
    """A float accessor of a GLB, one row per element."""
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    binary = data[20 + length + 8 :]
    a = doc["accessors"][index]
    view = doc["bufferViews"][a["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
    start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(binary, np.float32, a["count"] * width, start).reshape(a["count"], width)


def obj_positions(path: Path) -> np.ndarray:
    rows = [l.split()[1:4] for l in path.read_text().splitlines() if l.startswith("v ")]
    return np.array(rows, np.float64)


def test_shape_keys_in_blender_give_csrbf_deforms_positions(demos, tmp_path):
    """Blender's shape keys at sampled frames against `csrbf deform` of each
    control file at the phase the scene gives it then (the files of a part add)."""
    fish = demos / "d" / "fish"
    scene = json.loads((fish / "fish.scene.json").read_text())
    glb = tmp_path / "fish.glb"
    csrbf("export", "-q", fish / "fish.scene.json", "--out", glb)
    doc = glb_json(glb)
    anim = doc["animations"][0]
    (channel,) = [c for c in anim["channels"] if c["target"]["path"] == "weights"]
    files = [d["controls"] for d in scene["objects"][0]["parts"][0]["deformations"]]
    weights = accessor(glb, doc, anim["samplers"][channel["sampler"]]["output"]).reshape(-1, len(files))
    rest = obj_positions(fish / scene["objects"][0]["mesh"])
    n = len(rest)
    diagonal = np.linalg.norm(rest.max(0) - rest.min(0))
    fresh()
    bpy.context.scene.render.fps = int(scene.get("fps", 30))
    bpy.ops.import_scene.gltf(filepath=str(glb))
    (duck,) = meshes()
    for frame in (0, 40, 75, len(weights) - 1):
        want = rest.copy()
        for k, controls in enumerate(files):
            out = tmp_path / f"f{frame}_{k}.obj"
            phase = float(weights[frame, k])
            csrbf("deform", "-q", "--mesh", fish / scene["objects"][0]["mesh"], "--controls", fish / controls,
                  "--phase", repr(phase), "--out", out)
            want += obj_positions(out) - rest
        bpy.context.scene.frame_set(frame)
        evaluated = duck.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        co = np.zeros(3 * len(evaluated.vertices), np.float32)
        evaluated.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)[:n]  # the seam copies follow the mesh's own vertices
        got = np.stack([co[:, 0], co[:, 2], -co[:, 1]], 1)  # back to glTF's Y up
        err = np.abs(got - want).max() / diagonal
        assert err < 1e-6, (frame, err)


# Every format csrbf writes, the importer Blender has for it (none for OFF)
# and how that importer turns csrbf's Y-up coordinates (glTF's and OBJ's
# importers convert to Blender's Z-up; PLY's and STL's keep them).
FORMATS = {
    "obj": (lambda p: bpy.ops.wm.obj_import(filepath=p), True),
    "ply": (lambda p: bpy.ops.wm.ply_import(filepath=p), False),
    "stl": (lambda p: bpy.ops.wm.stl_import(filepath=p), False),
    "off": (None, False),
    "gltf": (lambda p: bpy.ops.import_scene.gltf(filepath=p), True),
    "glb": (lambda p: bpy.ops.import_scene.gltf(filepath=p), True),
}


def unique_rows(points: np.ndarray, diagonal: float) -> np.ndarray:
    """The distinct points, sorted: readers split vertices at seams (glTF)
    or not at all (STL's triangle soup), so positions compare as sets."""
    key = np.round(points / (diagonal * 1e-7)).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    rows = points[first]
    return rows[np.lexsort(rows.T[::-1])]


def blender_points(z_up: bool) -> tuple[np.ndarray, int]:
    """World positions of every imported mesh in csrbf's Y-up frame, and
    the triangles they make."""
    points, triangles = [], 0
    for obj in meshes():
        me = obj.data
        co = np.zeros(3 * len(me.vertices), np.float64)
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        m = np.array(obj.matrix_world)
        co = co @ m[:3, :3].T + m[:3, 3]
        points.append(np.stack([co[:, 0], co[:, 2], -co[:, 1]], 1) if z_up else co)
        me.calc_loop_triangles()
        triangles += len(me.loop_triangles)
    return np.concatenate(points), triangles


def trimesh_points(path: Path):
    import trimesh

    loaded = trimesh.load(path, process=False)
    if isinstance(loaded, trimesh.Scene):
        loaded = loaded.to_geometry() if hasattr(loaded, "to_geometry") else loaded.dump(concatenate=True)
    return np.asarray(loaded.vertices, np.float64), len(loaded.faces), loaded


@pytest.mark.parametrize("fmt", sorted(FORMATS))
def test_every_mesh_format_round_trips_through_trimesh_and_blender(tmp_path, fmt):
    """The deformed duck (UV seams, a material) in each format csrbf
    writes: Blender's importer and trimesh read the same triangles at the
    positions `csrbf deform` gives (its OBJ, parsed here, is the
    reference), UVs where the format keeps them, and csrbf says what a
    format drops."""
    controls = tmp_path / "c.json"
    controls.write_text(json.dumps({"radius": 0.3, "controls": [{"from": [0, 0.3, 0], "to": [0.05, 0.4, 0]}]}))
    duck = MODELS / "pybullet_duck.obj"
    ref = tmp_path / "ref" / "duck.obj"
    ref.parent.mkdir()
    csrbf("deform", "-q", "--mesh", duck, "--controls", controls, "--out", ref)
    rest = obj_positions(duck)
    diagonal = float(np.linalg.norm(rest.max(0) - rest.min(0)))
    want = unique_rows(obj_positions(ref), diagonal)
    triangles = sum(1 for l in ref.read_text().splitlines() if l.startswith("f "))
    assert not np.allclose(want, unique_rows(rest, diagonal), atol=1e-3 * diagonal)  # it moved

    out = tmp_path / f"duck.{fmt}"
    said = csrbf("deform", "--mesh", duck, "--controls", controls, "--out", out)
    if fmt in ("ply", "off"):
        assert "seams" in said and "OBJ or glTF" in said, said
    if fmt == "stl":
        assert "UVs" in said, said

    def same(points, n_triangles, reader):
        got = unique_rows(points, diagonal)
        assert got.shape == want.shape, (reader, got.shape, want.shape)
        err = np.abs(got - want).max() / diagonal
        assert err < 1e-6, (reader, err)
        assert n_triangles == triangles, (reader, n_triangles, triangles)

    points, n_triangles, loaded = trimesh_points(out)
    same(points, n_triangles, "trimesh")
    if fmt in ("obj", "gltf", "glb"):
        uv = loaded.visual.uv
        assert uv is not None and len(uv) == len(loaded.vertices) and np.ptp(uv) > 0.5, fmt

    importer, z_up = FORMATS[fmt]
    if importer is None:  # Blender has no OFF importer
        return
    fresh()
    assert importer(str(out)) == {"FINISHED"}
    points, n_triangles = blender_points(z_up)
    same(points, n_triangles, "blender")
    if fmt in ("obj", "gltf", "glb"):
        (obj,) = meshes()
        assert len(obj.data.uv_layers) == 1, fmt
        assert [m.name for m in obj.data.materials] == ["blinn3"], fmt
