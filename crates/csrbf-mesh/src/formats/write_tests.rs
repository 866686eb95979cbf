//! What writing keeps and names (issue 24): an OBJ's material library,
//! PLY's UV names, and what PLY and OFF say they cannot keep.

use std::path::{Path, PathBuf};

use crate::{Format, Mesh};

/// A fresh temporary folder, removed on drop.
struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("csrbf-mesh-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("dir");
        Dir(d)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const WITH_MATERIAL: &[u8] =
    b"mtllib duck.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl blinn3\nf 1 2 3\nusemtl red\nf 2 4 3\n";

fn mtllib(obj: &Path) -> Option<String> {
    let text = std::fs::read_to_string(obj).expect("obj");
    text.lines()
        .find_map(|l| l.strip_prefix("mtllib "))
        .map(str::to_owned)
}

/// Issue 24, item 3: a deformed duck's OBJ named `duck.mtl`, which was not there.
#[test]
fn an_obj_names_only_a_material_library_that_exists() {
    let d = Dir::new("mtllib");
    let mesh = Mesh::from_bytes(WITH_MATERIAL, Format::Obj, "duck.obj".as_ref()).expect("parse");
    assert_eq!(mesh.material_library.as_deref(), Some("duck.mtl"));
    // Elsewhere: its own library, with every material, is written beside it.
    let out = d.0.join("smile.obj");
    crate::write(&out, &mesh).expect("write");
    assert_eq!(mtllib(&out).as_deref(), Some("smile.mtl"));
    let mtl = std::fs::read_to_string(d.0.join("smile.mtl")).expect("the library is there");
    assert!(
        mtl.contains("newmtl blinn3") && mtl.contains("newmtl red"),
        "{mtl}"
    );
    let back = crate::read(&out).expect("read back");
    assert_eq!(back.part_vertices("red"), Some(vec![1, 2, 3]));
    // Beside the library it was read with: that one is named, not rewritten
    // (obj_material_tests::obj_beside_its_library_names_it); a library of the
    // same name that the mesh was not read from is not named (issue 25).
    std::fs::write(d.0.join("duck.mtl"), "newmtl blinn3\nKd 1 0 0\n").expect("mtl");
    let out = d.0.join("duck2.obj");
    crate::write(&out, &mesh).expect("write");
    assert_eq!(mtllib(&out).as_deref(), Some("duck2.mtl"));
    // Someone else's file in the way is left alone, and nothing is named.
    let mut moved = mesh.clone();
    moved.material_library = None;
    std::fs::write(d.0.join("theirs.mtl"), "newmtl mine\n").expect("mtl");
    let out = d.0.join("theirs.obj");
    crate::write(&out, &moved).expect("write");
    assert_eq!(mtllib(&out), None);
    assert_eq!(
        std::fs::read_to_string(d.0.join("theirs.mtl")).expect("mtl"),
        "newmtl mine\n"
    );
    // No materials: no library; and bytes in memory name none.
    let plain = Mesh::from_bytes(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        Format::Obj,
        "p.obj".as_ref(),
    )
    .expect("parse");
    let out = d.0.join("plain.obj");
    crate::write(&out, &plain).expect("write");
    assert_eq!(mtllib(&out), None);
    let bytes = mesh.to_bytes(Format::Obj).expect("bytes");
    assert!(!String::from_utf8_lossy(&bytes).contains("mtllib"));
}

/// A glTF model's colours and embedded texture go into the library.
#[test]
fn an_obj_from_gltf_keeps_its_materials_colour_and_texture() {
    let d = Dir::new("mtl-texture");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/models");
    let mesh = crate::read(&root.join("assimp_BoxTextured.glb")).expect("box");
    let out = d.0.join("box.obj");
    crate::write(&out, &mesh).expect("write");
    let lib = mtllib(&out).expect("a library");
    let mtl = std::fs::read_to_string(d.0.join(&lib)).expect("library");
    let map = mtl
        .lines()
        .find_map(|l| l.strip_prefix("map_Kd "))
        .expect("texture named");
    let (_, bytes) = mesh
        .materials
        .iter()
        .find_map(|m| m.texture.as_ref())
        .expect("box texture");
    assert_eq!(&std::fs::read(d.0.join(map)).expect("texture file"), bytes);
}

/// Issue 24, item 2: PLY wrote UVs as `u v`, which Blender keeps as plain
/// attributes (its reader takes `s t`), and PLY and OFF dropped parts and
/// seam UVs without a word.
#[test]
fn ply_uvs_are_s_t_and_ply_off_say_what_they_cannot_keep() {
    let per_vertex = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
    let mesh = Mesh::from_bytes(per_vertex, Format::Obj, "a.obj".as_ref()).expect("parse");
    for fmt in [Format::PlyAscii, Format::Ply] {
        let bytes = mesh.to_bytes(fmt).expect("ply");
        let text = String::from_utf8_lossy(&bytes);
        assert!(
            text.contains("property float s\nproperty float t\n"),
            "{text}"
        );
        let back = Mesh::from_bytes(&bytes, fmt, "a.ply".as_ref()).expect("read back");
        assert_eq!(
            back.uvs.and_then(|u| u.per_vertex(&back.faces, 3)),
            mesh.uvs.as_ref().and_then(|u| u.per_vertex(&mesh.faces, 3))
        );
    }
    // Neither parts nor UVs to lose: nothing said.
    for fmt in [Format::Ply, Format::Off, Format::Obj, Format::Glb] {
        assert_eq!(fmt.loses(&mesh), None, "{fmt:?}");
    }
    // Parts and a seam (vertex 2 has two UVs).
    let seams = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n\
g left\nf 1/1 2/2 3/3\ng right\nf 2/5 4/4 3/3\n";
    let mesh = Mesh::from_bytes(seams, Format::Obj, "b.obj".as_ref()).expect("parse");
    for fmt in [Format::Ply, Format::PlyAscii, Format::Off] {
        let said = fmt.loses(&mesh).unwrap_or_default();
        assert!(
            said.contains("left, right") && said.contains("seams") && said.contains("OBJ or glTF"),
            "{fmt:?}: {said}"
        );
    }
    // PLY keeps the parts as face properties, which csrbf reads back.
    for fmt in [Format::Ply, Format::PlyAscii] {
        let bytes = mesh.to_bytes(fmt).expect("ply");
        let back = Mesh::from_bytes(&bytes, fmt, "b.ply".as_ref()).expect("read back");
        assert_eq!(back.parts, mesh.parts, "{fmt:?}");
        assert!(
            fmt.loses(&mesh)
                .unwrap_or_default()
                .contains("face properties")
        );
    }
    for fmt in [Format::Obj, Format::Gltf] {
        assert_eq!(fmt.loses(&mesh), None, "{fmt:?}");
    }
}

/// Issue 24, item 4: a see-through material was written without
/// `alphaMode`, so glTF readers drew it opaque.
#[test]
fn a_see_through_material_is_blended_in_gltf() {
    let src = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nusemtl glass\nf 1 2 3\nusemtl wood\nf 2 4 3\n";
    let mut mesh = Mesh::from_bytes(src, Format::Obj, "a.obj".as_ref()).expect("parse");
    mesh.materials = vec![crate::Material::new("glass", [0.5, 0.7, 1.0, 0.3])];
    let bytes = mesh.to_bytes(Format::Gltf).expect("gltf");
    let doc: serde_json::Value = serde_json::from_slice(&bytes).expect("json");
    let mats = doc["materials"].as_array().expect("materials");
    let mode = |name: &str| {
        mats.iter()
            .find(|m| m["name"] == name)
            .map(|m| m["alphaMode"].clone())
    };
    assert_eq!(mode("glass"), Some(serde_json::json!("BLEND")));
    assert_eq!(mode("wood"), Some(serde_json::Value::Null));
}

/// PLY holds one part of each kind per face: a face in two groups keeps
/// the first, and the warning says so; names with spaces survive, and a
/// line break in a name cannot break the header.
#[test]
fn ply_parts_overlapping_or_oddly_named() {
    use crate::{Part, PartKind};
    let src = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    let mut mesh = Mesh::from_bytes(src, Format::Obj, "a.obj".as_ref()).expect("parse");
    let part = |name: &str, kind, faces: &[u32]| Part {
        name: name.into(),
        kind,
        faces: faces.to_vec(),
    };
    mesh.parts = vec![
        part("red  paint", PartKind::Material, &[1]),
        part("two\nlines", PartKind::Group, &[0]),
    ];
    let bytes = mesh.to_bytes(Format::PlyAscii).expect("ply");
    let back = Mesh::from_bytes(&bytes, Format::PlyAscii, "a.ply".as_ref()).expect("read back");
    assert_eq!(back.parts[0], part("two lines", PartKind::Group, &[0]));
    assert_eq!(back.parts[1], mesh.parts[0]);
    assert!(
        !Format::Ply
            .loses(&mesh)
            .unwrap_or_default()
            .contains("cannot keep")
    );
    mesh.parts.push(part("both", PartKind::Group, &[0, 1]));
    let said = Format::Ply.loses(&mesh).unwrap_or_default();
    assert!(said.contains("beyond the first of each kind"), "{said}");
    let back = Mesh::from_bytes(
        &mesh.to_bytes(Format::Ply).expect("ply"),
        Format::Ply,
        "a.ply".as_ref(),
    )
    .expect("read back");
    let groups: Vec<_> = back
        .parts
        .iter()
        .filter(|p| p.kind == PartKind::Group)
        .collect();
    assert_eq!(
        (groups[0].faces.as_slice(), groups[1].faces.as_slice()),
        (&[0u32][..], &[1u32][..])
    );
    // A PLY of another program with a bad part index: that face is in none.
    let other = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 2\nproperty list uchar int vertex_indices\nproperty int material\nend_header\n\
0 0 0\n1 0 0\n0 1 0\n3 0 1 2 -4\n3 0 2 1 2\n";
    let mesh = Mesh::from_bytes(other, Format::PlyAscii, "o.ply".as_ref()).expect("parse");
    assert_eq!(mesh.parts.len(), 1);
    assert_eq!(
        (mesh.parts[0].name.as_str(), &mesh.parts[0].faces[..]),
        ("material 2", &[1u32][..])
    );
}
