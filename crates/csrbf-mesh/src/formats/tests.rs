//! Every format on every real model, round trips and broken files.

use std::path::{Path, PathBuf};

use crate::{Format, Mesh, MeshError};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The bundled models, and those of `../shared/models` as an extra when that
/// folder is beside the checkout (said on standard error).
fn models() -> Vec<PathBuf> {
    let list = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        v.retain(|p| Format::from_path(p).is_ok());
        v.sort();
        v
    };
    let mut v = list(&root().join("assets/models"));
    let shared = root().join("../shared/models");
    if shared.is_dir() {
        let extra: Vec<PathBuf> = list(&shared)
            .into_iter()
            .filter(|p| !v.iter().any(|m| m.file_name() == p.file_name()))
            .collect();
        eprintln!(
            "also using {} models from {}",
            extra.len(),
            shared.display()
        );
        v.extend(extra);
    } else {
        eprintln!("{} not found: the bundled models only", shared.display());
    }
    assert!(
        v.len() >= 7,
        "the bundled models are missing from assets/models"
    );
    v
}

const OUT: [Format; 7] = [
    Format::Obj,
    Format::Ply,
    Format::PlyAscii,
    Format::Stl,
    Format::Off,
    Format::Gltf,
    Format::Glb,
];

#[test]
fn every_model_reads_and_round_trips_through_every_format() {
    let models = models();
    assert!(
        models.len() >= 5,
        "expected the real models, found {models:?}"
    );
    for path in models {
        let mesh = crate::read(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            !mesh.positions.is_empty() && !mesh.faces.is_empty(),
            "{}",
            path.display()
        );
        for fmt in OUT {
            let bytes = mesh.to_bytes(fmt).expect("encode");
            let back = Mesh::from_bytes(&bytes, fmt, Path::new("roundtrip"))
                .unwrap_or_else(|e| panic!("{} via {fmt:?}: {e}", path.display()));
            if fmt == Format::Stl {
                // STL welds equal positions: at most as many vertices, same triangles.
                assert!(back.positions.len() <= mesh.positions.len());
                assert_eq!(back.faces.len(), mesh.faces.triangle_count());
                continue;
            }
            assert_eq!(
                back.positions,
                mesh.positions,
                "{} via {fmt:?}: positions",
                path.display()
            );
            if matches!(fmt, Format::Gltf | Format::Glb) {
                assert_eq!(back.faces.len(), mesh.faces.triangle_count());
            } else {
                assert_eq!(
                    back.faces,
                    mesh.faces,
                    "{} via {fmt:?}: faces",
                    path.display()
                );
            }
            if mesh.colors.is_some() && fmt != Format::Stl {
                assert!(
                    back.colors.is_some(),
                    "{} via {fmt:?} lost colours",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn obj_keeps_groups_materials_and_corner_uvs() {
    let src = b"mtllib m.mtl\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nv 1 1 0 1 1 1\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
o body\ng left\nusemtl red\nf 1/1 2/2 3/3\ng right top\nusemtl blue\nf 2/2 4/4 3/3\nf -3/-3 -1/-1 -2/-2\n";
    let m = Mesh::from_bytes(src, Format::Obj, Path::new("a.obj")).expect("parse");
    assert_eq!(m.part_vertices("left"), Some(vec![0, 1, 2]));
    assert_eq!(m.part_vertices("top"), Some(vec![1, 2, 3]));
    assert_eq!(m.part_vertices("blue"), Some(vec![1, 2, 3]));
    assert_eq!(m.part_vertices("body"), Some(vec![0, 1, 2, 3]));
    assert_eq!(m.colors.as_ref().map(|c| c[1]), Some([0.0, 1.0, 0.0, 1.0]));
    assert_eq!(m.material_library.as_deref(), Some("m.mtl"));
    let back = Mesh::from_bytes(
        &m.to_bytes(Format::Obj).expect("enc"),
        Format::Obj,
        Path::new("b.obj"),
    )
    .expect("parse");
    assert_eq!(back.faces, m.faces);
    assert_close_uvs(&back, &m);
    for name in ["left", "right", "top", "red", "blue", "body"] {
        assert_eq!(back.part_vertices(name), m.part_vertices(name), "{name}");
    }
}

#[test]
fn gltf_keeps_materials_textures_and_uvs() {
    let path = root().join("assets/models/assimp_BoxTextured.glb");
    let m = crate::read(&path).expect("read");
    assert!(m.uvs.is_some());
    assert!(
        m.materials.iter().any(|mat| mat.texture.is_some()),
        "{:?}",
        m.materials
    );
    let back = Mesh::from_bytes(
        &m.to_bytes(Format::Glb).expect("enc"),
        Format::Glb,
        Path::new("x.glb"),
    )
    .expect("parse");
    assert_close_uvs(&back, &m);
    assert_eq!(back.materials.len(), m.materials.len());
    assert_eq!(back.materials[0].texture, m.materials[0].texture);
}

fn parse_err(bytes: &[u8], fmt: Format) -> String {
    match Mesh::from_bytes(bytes, fmt, Path::new("bad.x")) {
        Ok(m) => panic!(
            "{fmt:?} accepted a broken file: {} vertices",
            m.positions.len()
        ),
        Err(e) => e.to_string(),
    }
}

#[test]
fn broken_files_are_errors_that_name_the_place() {
    let cases: &[(&[u8], Format, &str)] = &[
        (b"v 0 0 0\nv 1 0 0\nv 0 1\nf 1 2 3\n", Format::Obj, "bad.x:3: a vertex needs 3 coordinates"),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", Format::Obj, "bad.x:4: vertex index 9 is out of range"),
        (b"v 0 0 0\nv 1 x 0\n", Format::Obj, "bad.x:2: vertex coordinate: \"x\""),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", Format::Obj, "at least 3 corners"),
        (b"v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", Format::Obj, "vertex 0 has a coordinate that is not finite"),
        (b"# nothing\n", Format::Obj, "no vertices"),
        (b"OFF\n3 1 0\n0 0 0\n1 0 0\n", Format::Off, "truncated: expected 3 vertices, found 2"),
        // Issue 42: a face line read as a vertex is not counted as one.
        (
            b"OFF\n5 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            Format::Off,
            "truncated: expected 5 vertices, found 3 and then 1 face line(s) (if the file is whole, the header's vertex count is too large)",
        ),
        (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", Format::Off, "bad.x:6: face 0 refers to vertex 7"),
        (b"PFF\n", Format::Off, "expected the OFF header"),
        (b"OFF\n", Format::Off, "no vertex and face counts"),
        (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n", Format::Ply, "truncated"),
        (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", Format::Ply, "face 0 refers to vertex 5"),
        (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0", Format::Ply, "truncated in vertex 0"),
        (b"ply\nformat ascii 1.0\nelement vertex 1\n", Format::Ply, "end_header"),
        (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n", Format::Stl, "truncated"),
        (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0\n", Format::Stl, "bad.x:5: missing vertex z"),
        (&[0u8; 90], Format::Stl, "truncated or not an STL file"),
        (b"{\"asset\":{\"version\":\"2.0\"},\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":5}}]}]}", Format::Gltf, "names accessor 5, but there are 0"),
        (b"glTF\x02\0\0\0\xff\0\0\0", Format::Glb, "the GLB header says 255 bytes"),
        (b"{not json", Format::Gltf, "invalid glTF"),
    ];
    for (bytes, fmt, want) in cases {
        let e = parse_err(bytes, *fmt);
        assert!(
            e.contains(want),
            "{fmt:?}: message {e:?} does not contain {want:?}"
        );
        assert!(e.starts_with("bad.x"), "{e:?} does not name the file");
    }
}

#[test]
fn truncated_real_files_never_panic() {
    for path in models() {
        let bytes = std::fs::read(&path).expect("read");
        let fmt = Format::from_path(&path).expect("format");
        for k in 1..12 {
            let cut = bytes.len() * k / 12;
            // An error, or (for text cut at a line end) a valid smaller mesh; never a panic.
            if let Ok(m) = Mesh::from_bytes(&bytes[..cut], fmt, &path) {
                m.validate(&path).expect("a mesh that reads is valid");
            }
        }
    }
}

#[test]
fn unknown_extension_lists_the_supported_ones() {
    let e = crate::read(Path::new("model.fbx"))
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("model.fbx") && e.contains(".obj") && e.contains(".glb"),
        "{e}"
    );
    assert!(matches!(
        crate::read(Path::new("/nonexistent/a.obj")),
        Err(MeshError::Read { .. })
    ));
}

/// Issue 23, bug 6: a file replaced keeps its permissions (a read-only
/// file stays read-only, a private one private).
#[cfg(unix)]
#[test]
fn a_file_replaced_keeps_its_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = std::env::temp_dir().join(format!("csrbf-mesh-perm-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    for mode in [0o444, 0o600, 0o640] {
        let target = dir.join(format!("m{mode:o}.json"));
        std::fs::write(&target, b"old").expect("write");
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(mode)).expect("chmod");
        crate::write_atomic(&target, b"new").expect("replaced");
        assert_eq!(std::fs::read(&target).expect("read"), b"new");
        let now = std::fs::metadata(&target)
            .expect("meta")
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(now, mode, "{}", target.display());
    }
    // A new file gets the usual mode (not one left from before).
    let fresh = dir.join("fresh.json");
    crate::write_atomic(&fresh, b"x").expect("written");
    assert!(
        !std::fs::metadata(&fresh)
            .expect("meta")
            .permissions()
            .readonly()
    );
    for e in std::fs::read_dir(&dir).expect("dir").flatten() {
        let _ = std::fs::set_permissions(e.path(), std::fs::Permissions::from_mode(0o644));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn atomic_write_leaves_no_partial_file() {
    let dir = std::env::temp_dir().join(format!("csrbf-mesh-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let target = dir.join("m.obj");
    std::fs::write(&target, b"old").expect("write");
    // A mesh that fails validation is refused before anything is written.
    let bad = Mesh::default();
    assert!(crate::write(&target, &bad).is_err());
    assert_eq!(std::fs::read(&target).expect("read"), b"old");
    // Writing into a missing directory fails and leaves nothing behind.
    assert!(crate::write_atomic(&dir.join("missing/x.obj"), b"data").is_err());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .expect("dir")
        .filter_map(|e| e.ok())
        .collect();
    assert_eq!(leftovers.len(), 1);
    std::fs::remove_dir_all(&dir).ok();
}

/// What a file holds and a mesh does not keep is one warning naming the
/// file and counting each kind: an OBJ's lines, points and unknown
/// statements; a PLY's other elements and properties; an OFF's face
/// colours. A file with nothing skipped has no such warning, and an NOFF's
/// normals are kept.
#[test]
fn what_a_reader_skips_is_said() {
    let dir = std::env::temp_dir().join(format!("csrbf-mesh-skipped-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let ply = |extra_vertex: &str, extra_face: &str, tail: &str| {
        format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{}element face 1\nproperty list uchar int vertex_indices\n{}{}end_header\n",
            extra_vertex, extra_face, tail
        )
    };
    let cases: [(&str, String, &[&str]); 5] = [
        ("plain.obj", tri.to_owned(), &[]),
        (
            "lines.obj",
            format!("{tri}l 1 2\nl 2 3\np 1\ncstype bspline\nl 3 1\n"),
            &[
                "polylines (`l`): 3",
                "points (`p`): 1",
                "`cstype` statements: 1",
            ],
        ),
        (
            "quality.ply",
            ply(
                "property float quality\nproperty float nx\n",
                "property uchar red\n",
                "element edge 2\nproperty int vertex1\nproperty int vertex2\n",
            ) + "0 0 0 1 0\n1 0 0 1 0\n0 1 0 1 0\n3 0 1 2 255\n0 1\n1 2\n",
            &["vertices' `quality`: 3, vertices' `nx`: 3, faces' `red`: 1, `edge` elements: 2"],
        ),
        (
            "colours.off",
            "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 1 0 0\n3 0 2 1\n".to_owned(),
            &["faces' colours: 1"],
        ),
        (
            "normals.off",
            "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n".to_owned(),
            &[],
        ),
    ];
    for (file, text, want) in cases {
        let path = dir.join(file);
        std::fs::write(&path, text).expect("write");
        let loaded = crate::load(&path).expect(file);
        let said: Vec<&String> = loaded
            .warnings
            .iter()
            .filter(|w| w.contains("not kept"))
            .collect();
        if want.is_empty() {
            assert!(said.is_empty(), "{file}: {said:?}");
            continue;
        }
        assert_eq!(said.len(), 1, "{file}: {:?}", loaded.warnings);
        assert!(
            said[0].starts_with(&path.display().to_string()),
            "{}",
            said[0]
        );
        for w in want {
            assert!(said[0].contains(w), "{file}: {w:?} in {}", said[0]);
        }
    }
    // Made-up keywords by the thousand: a few kinds named, the rest together.
    let many: String = (0..5000).map(|k| format!("x{k} 1\n")).collect();
    let path = dir.join("many.obj");
    std::fs::write(&path, format!("{tri}{many}")).expect("write");
    let warnings = crate::load(&path).expect("many").warnings;
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].len() < 600, "{}", warnings[0]);
    assert!(
        warnings[0].ends_with("`x11` statements: 1, and other kinds"),
        "{}",
        warnings[0]
    );
    // A name from the file is escaped and cut.
    let path = dir.join("odd.ply");
    let odd = format!("x\u{1b}[31m{}", "y".repeat(100));
    std::fs::write(
        &path,
        ply(&format!("property float {odd}\n"), "", "") + "0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n",
    )
    .expect("write");
    let warnings = crate::load(&path).expect("odd").warnings;
    assert!(
        warnings[0].ends_with("vertices' `x\\u{1b}[31myyyyyyyyyyyyyyyyyyyyy...`: 3"),
        "{}",
        warnings[0]
    );
    // What csrbf writes has nothing skipped: a PLY and an OFF with colours,
    // UVs, normals (and parts, in the PLY) read back without the warning,
    // the PLY with its normals (an OFF is written without them).
    let mut m = crate::read(&root().join("assets/models/cgal_head.off")).expect("head");
    let n = m.positions.len();
    m.colors = Some(
        (0..n)
            .map(|k| [k as f32 / n as f32, 0.5, 1.0, 1.0])
            .collect(),
    );
    let uvs = m
        .positions
        .iter()
        .map(|p| glam::Vec2::new(p.x, p.y))
        .collect();
    m.uvs = Some(crate::TexCoords {
        values: uvs,
        corners: None,
    });
    m.normals = Some(
        m.positions
            .iter()
            .map(|p| p.normalize_or(glam::Vec3::Z))
            .collect(),
    );
    let half = (0..m.faces.len() as u32 / 2).collect();
    m.parts = vec![crate::Part {
        name: "half".into(),
        kind: crate::PartKind::Group,
        faces: half,
    }];
    for file in ["all.ply", "all.off"] {
        let path = dir.join(file);
        crate::write(&path, &m).expect("write");
        let loaded = crate::load(&path).expect(file);
        assert!(loaded.warnings.is_empty(), "{file}: {:?}", loaded.warnings);
        if file.ends_with(".ply") {
            assert_eq!(loaded.mesh.normals, m.normals, "{file}");
        }
    }
    let noff = crate::load(&dir.join("normals.off")).expect("noff").mesh;
    assert_eq!(noff.normals, Some(vec![glam::Vec3::Z; 3]));
    std::fs::remove_dir_all(&dir).ok();
}

/// A glTF written to a file names its object after the file (what a
/// Blender import shows); bytes made in memory name it `mesh`.
#[test]
fn a_written_gltf_names_its_object_after_the_file() {
    let dir = std::env::temp_dir().join(format!("csrbf-mesh-name-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let m = crate::read(&root().join("assets/models/assimp_BoxTextured.glb")).expect("read");
    let names = |doc: &serde_json::Value| {
        ["nodes", "meshes"].map(|k| doc[k][0]["name"].as_str().unwrap_or("").to_owned())
    };
    for (file, glb) in [("box_bent.gltf", false), ("box.bent.glb", true)] {
        let path = dir.join(file);
        crate::write(&path, &m).expect("write");
        let bytes = std::fs::read(&path).expect("read");
        let json = if glb {
            // The JSON chunk: its length at byte 12, its text from 20.
            let n = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
            bytes[20..20 + n].to_vec()
        } else {
            bytes
        };
        let doc: serde_json::Value = serde_json::from_slice(&json).expect("json");
        let stem = file.rsplit_once('.').map_or(file, |(s, _)| s);
        assert_eq!(names(&doc), [stem, stem], "{file}");
    }
    let bytes = m.to_bytes(Format::Gltf).expect("encode");
    let doc: serde_json::Value = serde_json::from_slice(&bytes).expect("json");
    assert_eq!(names(&doc), ["mesh", "mesh"]);
    std::fs::remove_dir_all(&dir).ok();
}

/// Texture coordinates equal within rounding (glTF flips v on the way in and out).
#[track_caller]
fn assert_close_uvs(a: &Mesh, b: &Mesh) {
    let (Some(a), Some(b)) = (&a.uvs, &b.uvs) else {
        assert_eq!(a.uvs.is_some(), b.uvs.is_some());
        return;
    };
    assert_eq!(a.corners, b.corners);
    assert_eq!(a.values.len(), b.values.len());
    for (x, y) in a.values.iter().zip(&b.values) {
        assert!((*x - *y).length() < 1e-6, "{x} vs {y}");
    }
}

#[test]
fn triangles_know_their_faces() {
    let mut faces = crate::Faces::new();
    faces.push(&[0, 1, 2]);
    faces.push(&[0, 2, 3, 4, 5]);
    faces.push(&[1, 2, 3, 4]);
    let owners: Vec<usize> = (0..faces.triangle_count())
        .map(|t| faces.face_of_triangle(t))
        .collect();
    assert_eq!(owners, vec![0, 1, 1, 1, 2, 2]);
}

#[test]
fn up_is_guessed_from_the_format_and_the_shape() {
    let tall = Mesh {
        positions: vec![glam::Vec3::ZERO, glam::Vec3::new(1.0, 1.0, 5.0)],
        ..Default::default()
    };
    assert_eq!(crate::guess_up(&tall, Path::new("a.obj")).0, glam::Vec3::Z);
    assert_eq!(crate::guess_up(&tall, Path::new("a.glb")).0, glam::Vec3::Y);
    let mut wide = tall.clone();
    wide.positions[1] = glam::Vec3::new(5.0, 1.0, 1.0);
    assert_eq!(crate::guess_up(&wide, Path::new("a.off")).0, glam::Vec3::Y);
    assert_eq!(crate::guess_up(&wide, Path::new("a.stl")).0, glam::Vec3::Z);
}

/// Issue 6: glTF reads back what it writes: four materials over one set of
/// vertices, groups and objects, and UVs with seams, vertex for vertex.
#[test]
fn gltf_reads_back_parts_shared_vertices_and_uv_seams() {
    let src = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 0 0\nv 2 1 0\n\
vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nvt 0.5 0.5\n\
o body\ng left\nusemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 2/2 4/4 3/3\n\
g right\nusemtl c\nf 2/5 5/2 6/4\nusemtl d\nf 2/5 6/4 4/3\n";
    let m = Mesh::from_bytes(src, Format::Obj, Path::new("a.obj")).expect("parse");
    assert!(
        m.uvs
            .as_ref()
            .is_some_and(|u| u.per_vertex(&m.faces, 6).is_none()),
        "the test needs a seam"
    );
    for fmt in [Format::Glb, Format::Gltf] {
        let back = Mesh::from_bytes(&m.to_bytes(fmt).expect("enc"), fmt, Path::new("b.glb"))
            .expect("read back");
        assert_eq!(back.positions, m.positions, "{fmt:?}: vertices");
        assert_eq!(back.faces, m.faces, "{fmt:?}: faces");
        for name in ["left", "right", "body", "a", "b", "c", "d"] {
            assert_eq!(
                back.part_vertices(name),
                m.part_vertices(name),
                "{fmt:?}: part {name}"
            );
        }
        // The same UV at every face corner.
        let uv_at = |mesh: &Mesh, c: usize| {
            let u = mesh.uvs.as_ref().expect("uvs");
            u.values[u.corners.as_ref().map_or(mesh.faces.indices[c], |k| k[c]) as usize]
        };
        for c in 0..m.faces.indices.len() {
            assert!(
                (uv_at(&back, c) - uv_at(&m, c)).length() < 1e-6,
                "{fmt:?}: corner {c}"
            );
        }
    }
}

/// Issue 7: a glTF from the web must not read local files.
#[test]
fn gltf_buffers_outside_the_model_folder_are_refused() {
    for uri in [
        "http://example.com/a.bin",
        "file:///etc/passwd",
        "../secret.bin",
        "/etc/passwd",
        "sub/../../x.bin",
        "C:/x.bin",
    ] {
        let doc = format!(
            r#"{{"asset": {{"version": "2.0"}}, "buffers": [{{"uri": "{uri}", "byteLength": 4}}]}}"#
        );
        let e = parse_err(doc.as_bytes(), Format::Gltf);
        assert!(
            e.contains("is refused") && e.contains("own folder"),
            "{uri}: {e}"
        );
    }
}

/// A one-triangle (or strip) glTF over 4 float vertices, with extra JSON
/// spliced into its first primitive, its accessors and its nodes.
fn tiny_gltf(primitive_extra: &str, accessors_extra: &str, nodes: &str) -> Vec<u8> {
    let mut bin = Vec::new();
    for v in [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u32, 1, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        crate::formats::gltf::encode_base64_for_tests(&bin)
    );
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": {nodes},
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}{primitive_extra}}}]}}],
        "buffers": [{{"uri": "{uri}", "byteLength": {}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 16}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
                      {{"bufferView": 1, "componentType": 5125, "count": 4, "type": "SCALAR"}}{accessors_extra}]}}"#,
        bin.len()
    )
    .into_bytes()
}

/// Issue 7: malformed glTF is an error, never a panic (no panic text at all).
#[test]
fn gltf_accessor_types_and_hierarchies_are_checked_before_reading() {
    let one = r#"[{"mesh": 0}]"#;
    let cases: Vec<(Vec<u8>, &str)> = vec![
        // Indices pointing at a float VEC3 accessor, or at signed bytes.
        (
            tiny_gltf(r#", "indices": 0"#, "", one),
            "indices accessor 0 is Vec3",
        ),
        (
            tiny_gltf(
                r#", "indices": 2"#,
                r#", {"bufferView": 1, "componentType": 5120, "count": 4, "type": "SCALAR"}"#,
                one,
            ),
            "indices accessor 2",
        ),
        // COLOR_0 and TEXCOORD_0 on a u32 SCALAR accessor.
        (
            tiny_gltf(r#", "indices": 1"#, "", one)
                .into_iter()
                .collect::<Vec<u8>>(),
            "",
        ),
        // A cycle through the mesh node, and a node with two parents.
        (
            tiny_gltf("", "", r#"[{"mesh": 0, "children": [0]}]"#),
            "cycle",
        ),
        (
            tiny_gltf(
                "",
                "",
                r#"[{"mesh": 0, "children": [2]}, {"children": [2]}, {}]"#,
            ),
            "child of both",
        ),
        // Points are not read.
        (
            tiny_gltf(r#", "mode": 0"#, "", one),
            "mode Points is not supported",
        ),
        // An accessor longer than its view.
        (
            tiny_gltf(
                r#", "indices": 2"#,
                r#", {"bufferView": 1, "componentType": 5125, "count": 400, "type": "SCALAR"}"#,
                one,
            ),
            "outside its buffer view",
        ),
    ];
    for (bytes, want) in cases {
        if want.is_empty() {
            // A well-formed file (indices as u32) still reads: 4 indices is not a whole number of triangles.
            let e = parse_err(&bytes, Format::Gltf);
            assert!(e.contains("not a whole number of triangles"), "{e}");
            continue;
        }
        let e = parse_err(&bytes, Format::Gltf);
        assert!(e.contains(want), "{want}: {e}");
    }
    for attr in ["COLOR_0", "TEXCOORD_0"] {
        let bytes = tiny_gltf(
            &format!(r#", "indices": 1, "attributes": {{"POSITION": 0, "{attr}": 1}}"#),
            "",
            one,
        );
        let text = String::from_utf8(bytes).expect("utf-8").replace(
            r#""attributes": {"POSITION": 0}, "indices""#,
            r#""indices""#,
        );
        let e = parse_err(text.as_bytes(), Format::Gltf);
        assert!(e.contains("accessor 1 is Scalar"), "{attr}: {e}");
    }
    // Strips are read as triangles: 4 strip indices give 2 triangles.
    let strip = tiny_gltf(r#", "indices": 1, "mode": 5"#, "", one);
    let m = Mesh::from_bytes(&strip, Format::Gltf, Path::new("s.gltf")).expect("strip");
    assert_eq!(m.faces.len(), 2);
    assert_eq!(m.faces.face(1), &[2, 1, 3]);
}

/// Issue 7: a count that asks for more than the line holds is refused before
/// anything is allocated.
#[test]
fn off_face_counts_are_checked_against_the_line() {
    for count in ["18446744073709551615", "40000000000"] {
        let text = format!("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n{count} 0 1 2\n");
        let e = parse_err(text.as_bytes(), Format::Off);
        assert!(
            e.contains("corners but its line holds 3 numbers") || e.contains("face corner count"),
            "{e}"
        );
    }
}

/// Issue 7: a byte-order mark before a text file is accepted.
#[test]
fn text_files_with_a_byte_order_mark_read() {
    let bom = "\u{feff}";
    let cases = [
        (
            Format::Obj,
            format!("{bom}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
        ),
        (
            Format::Off,
            format!("{bom}OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        ),
        (
            Format::Stl,
            format!(
                "{bom}solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n"
            ),
        ),
        (
            Format::Ply,
            format!(
                "{bom}ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
            ),
        ),
    ];
    for (fmt, text) in cases {
        let m = Mesh::from_bytes(text.as_bytes(), fmt, Path::new("bom"))
            .unwrap_or_else(|e| panic!("{fmt:?}: {e}"));
        assert_eq!((m.positions.len(), m.faces.len()), (3, 1), "{fmt:?}");
    }
}

/// Issue 7: coordinates beyond f32 are named with their line; CR-only files read.
#[test]
fn overflowing_coordinates_are_named_and_cr_only_files_read() {
    let e = parse_err(b"v 0 0 1e39\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", Format::Obj);
    assert!(
        e.contains("bad.x:1:") && e.contains("1e39 is beyond the range of 32-bit floats"),
        "{e}"
    );
    let e = parse_err(
        b"OFF\n3 1 0\n0 0 0\n1e300 0 0\n0 1 0\n3 0 1 2\n",
        Format::Off,
    );
    assert!(
        e.contains("bad.x:4:") && e.contains("beyond the range"),
        "{e}"
    );
    let e = parse_err(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nend_header\n0 0 0\n1e300 0 0\n0 1 0\n", Format::Ply);
    assert!(e.contains("beyond the range"), "{e}");
    let m = Mesh::from_bytes(
        b"v 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r",
        Format::Obj,
        Path::new("mac.obj"),
    )
    .expect("CR only");
    assert_eq!((m.positions.len(), m.faces.len()), (3, 1));
}

/// A glTF from another tool keeps its normals: read as given (a deformation
/// then carries them, `Mesh::move_vertices`), so a sphere split at its seams
/// comes back with equal normals on every copy, and unchanged where nothing
/// moved.
#[test]
fn gltf_normals_are_read_and_carried_across_seams() {
    let welded = crate::shapes::uv_sphere(1.0, 8, 16);
    let smooth = crate::vertex_normals(&welded.positions, &welded.faces);
    // Every face its own corners (no UVs, so no csrbf extras weld them back).
    let mut m = Mesh::default();
    let mut normals = Vec::new();
    for f in welded.faces.iter() {
        let base = m.positions.len() as u32;
        for &v in f {
            m.positions.push(welded.positions[v as usize]);
            normals.push(smooth[v as usize]);
        }
        m.faces
            .push(&(base..base + f.len() as u32).collect::<Vec<_>>());
    }
    m.normals = Some(normals.clone());
    let bytes = m.to_bytes(Format::Glb).expect("enc");
    let mut back = Mesh::from_bytes(&bytes, Format::Glb, Path::new("s.glb")).expect("parse");
    let read = back.normals.clone().expect("the file's normals are read");
    for (i, (a, b)) in normals.iter().zip(&read).enumerate() {
        assert!((*a - *b).length() < 1e-6, "vertex {i}: {a} read as {b}");
    }
    let moved: Vec<glam::Vec3> = back
        .positions
        .iter()
        .map(|p| *p + glam::Vec3::new(0.3 * p.y * p.y, 0.0, 0.2 * p.x))
        .collect();
    back.move_vertices(moved);
    let n = back.normals.as_ref().expect("normals");
    for i in 0..back.positions.len() {
        for j in i + 1..back.positions.len() {
            if back.positions[i] == back.positions[j] {
                let angle = n[i].angle_between(n[j]).to_degrees();
                assert!(angle < 1e-3, "copies {i} and {j} differ by {angle} degrees");
            }
        }
    }
}

/// Issue 7, again: a symlink in the model's folder that points out of it is
/// refused like a `..` URI.
#[cfg(unix)]
#[test]
fn gltf_symlinks_out_of_the_model_folder_are_refused() {
    let dir = std::env::temp_dir().join(format!("csrbf-symlink-{}", std::process::id()));
    let (model, outside) = (dir.join("model"), dir.join("outside"));
    std::fs::create_dir_all(&model).expect("mkdir");
    std::fs::create_dir_all(&outside).expect("mkdir");
    std::fs::write(outside.join("secret.bin"), [0u8; 4]).expect("write");
    std::fs::write(model.join("inside.bin"), [0u8; 4]).expect("write");
    for link in ["link.bin", "link.png"] {
        let _ = std::fs::remove_file(model.join(link));
    }
    std::os::unix::fs::symlink(outside.join("secret.bin"), model.join("link.bin"))
        .expect("symlink");
    let doc = |uri: &str| {
        format!(
            r#"{{"asset": {{"version": "2.0"}}, "buffers": [{{"uri": "{uri}", "byteLength": 4}}]}}"#
        )
    };
    let read = |uri: &str| {
        let path = model.join("m.gltf");
        std::fs::write(&path, doc(uri)).expect("write");
        crate::read(&path)
    };
    let e = read("link.bin").expect_err("a symlink out of the folder is followed");
    let e = e.to_string();
    assert!(
        e.contains("\"link.bin\"") && e.contains("leaves the model's folder"),
        "{e}"
    );
    // An image through such a link too (it was silently followed).
    std::os::unix::fs::symlink(outside.join("secret.bin"), model.join("link.png"))
        .expect("symlink");
    let path = model.join("t.gltf");
    let image = tiny_gltf(
        r#", "indices": 1, "mode": 5, "material": 0"#,
        "",
        r#"[{"mesh": 0}], "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}], "images": [{"uri": "link.png"}]"#,
    );
    std::fs::write(&path, image).expect("write");
    let e = crate::read(&path).expect_err("an image through a symlink out of the folder is read");
    assert!(e.to_string().contains("\"link.png\""), "{e}");
    // A file really inside is still read (the file has no mesh: an empty
    // document is an error of its own, not a refusal).
    if let Err(e) = read("inside.bin") {
        assert!(!e.to_string().contains("refused"), "{e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A glTF round trip keeps the material's properties: metallic 0.9 came
/// back 0, roughness 0.3 came back 0.8, emission, double-sidedness and the
/// sampler's filters were dropped.
#[test]
fn gltf_round_trips_material_properties() {
    let path = root().join("assets/models/assimp_BoxTextured.glb");
    let mut m = crate::read(&path).expect("read");
    // BoxTextured leaves roughness out: glTF's default, 1, not csrbf's 0.8.
    assert_eq!(m.materials[0].roughness, 1.0, "{:?}", m.materials[0]);
    let round_trip = |m: &Mesh| {
        let bytes = m.to_bytes(Format::Glb).expect("enc");
        Mesh::from_bytes(&bytes, Format::Glb, Path::new("x.glb")).expect("parse")
    };
    // Compared without the image bytes (kept too, but unreadable in a
    // failure's message).
    let look = |m: &Mesh| -> Vec<crate::Material> {
        m.materials
            .iter()
            .map(|mat| {
                let mut mat = mat.clone();
                let short = |(mime, bytes): (String, Vec<u8>)| (mime, vec![bytes.len() as u8]);
                mat.texture = mat.texture.map(short);
                for t in [&mut mat.normal_texture, &mut mat.occlusion_texture]
                    .into_iter()
                    .flatten()
                {
                    t.image = short(t.image.clone());
                }
                mat
            })
            .collect()
    };
    assert_eq!(look(&round_trip(&m)), look(&m));
    let mat = &mut m.materials[0];
    mat.metallic = 0.9;
    mat.roughness = 0.3;
    mat.emissive = [1.0, 0.0, 0.0];
    mat.double_sided = true;
    mat.alpha_mode = Some(crate::AlphaMode::Mask(0.25));
    mat.sampler = Some(crate::Sampler {
        mag_filter: Some(9729),
        min_filter: Some(9986),
        wrap_s: Some(33071),
        wrap_t: None,
    });
    // The other maps (here the same image), with their own samplers.
    let image = mat.texture.clone().expect("BoxTextured has a texture");
    mat.normal_texture = Some(crate::TextureMap {
        image: image.clone(),
        sampler: Some(crate::Sampler {
            mag_filter: Some(9728),
            ..crate::Sampler::default()
        }),
        scale: 0.5,
    });
    mat.occlusion_texture = Some(crate::TextureMap {
        image: image.clone(),
        sampler: Some(crate::Sampler::default()),
        scale: 0.75,
    });
    let back = round_trip(&m);
    assert_eq!(look(&back), look(&m));
    let normal = back.materials[0]
        .normal_texture
        .as_ref()
        .expect("normal map");
    assert_eq!(normal.image, image);
    assert_eq!(back.materials[0].texture, m.materials[0].texture);
}

/// A glTF material that leaves its factors out reads as glTF's defaults.
#[test]
fn gltf_material_defaults_are_gltfs() {
    let bytes = tiny_gltf(
        r#", "indices": 1, "mode": 5, "material": 0"#,
        "",
        r#"[{"mesh": 0}], "materials": [{"name": "bare"}]"#,
    );
    let m = Mesh::from_bytes(&bytes, Format::Gltf, Path::new("d.gltf")).expect("parse");
    let mut want = crate::Material::new("bare", [1.0; 4]);
    want.metallic = 1.0;
    want.roughness = 1.0;
    want.alpha_mode = Some(crate::AlphaMode::Opaque);
    assert_eq!(m.materials, vec![want]);
}
