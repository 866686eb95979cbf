"""csrbf's exports opened by the programs users open them in (issue 24):
Blender's own glTF, OBJ and PLY importers, headless (the bpy module), and
trimesh where it is installed. Every file is made here by the `csrbf`
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
    trimesh = pytest.importorskip("trimesh")
    pytest.importorskip("PIL")  # trimesh decodes images with Pillow
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
