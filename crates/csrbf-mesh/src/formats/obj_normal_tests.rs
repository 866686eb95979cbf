//! OBJ normals (`vn`, `f v/vt/vn`): read, kept per corner where a vertex
//! has several (hard edges), carried through a deformation and written back
//! to OBJ and glTF. Before, the reader counted `vn` lines and dropped them.

use std::fmt::Write;
use std::path::Path;

use glam::{Quat, Vec3};

use crate::{Format, Mesh, MeshError, shapes};

fn read(text: &str) -> crate::Result<Mesh> {
    Mesh::from_bytes(text.as_bytes(), Format::Obj, Path::new("n.obj"))
}

/// A unit cube as Blender writes it with flat shading: 8 vertices, one `vn`
/// per face, every corner naming its face's normal.
fn cube_obj() -> String {
    let mut s = String::new();
    for z in [-1.0, 1.0] {
        for y in [-1.0, 1.0] {
            for x in [-1.0, 1.0] {
                let _ = writeln!(s, "v {x} {y} {z}");
            }
        }
    }
    // Vertex k is at (x, y, z) with bits (k & 1, k & 2, k & 4); faces
    // counter-clockwise seen from outside.
    let faces: [([u32; 4], [i32; 3]); 6] = [
        ([0, 2, 3, 1], [0, 0, -1]),
        ([4, 5, 7, 6], [0, 0, 1]),
        ([0, 1, 5, 4], [0, -1, 0]),
        ([2, 6, 7, 3], [0, 1, 0]),
        ([0, 4, 6, 2], [-1, 0, 0]),
        ([1, 3, 7, 5], [1, 0, 0]),
    ];
    for (_, [x, y, z]) in faces {
        let _ = writeln!(s, "vn {x} {y} {z}");
    }
    for (k, (f, _)) in faces.iter().enumerate() {
        s.push('f');
        for v in f {
            let _ = write!(s, " {}//{}", v + 1, k + 1);
        }
        s.push('\n');
    }
    s
}

/// Each face's corners' normals, as (face, corner normals).
fn corner_normals(m: &Mesh) -> Vec<Vec<Vec3>> {
    let c = m.corner_normals.as_ref().expect("corner normals");
    assert_eq!(c.len(), m.faces.indices.len());
    (0..m.faces.len())
        .map(|f| c[m.faces.offsets[f] as usize..m.faces.offsets[f + 1] as usize].to_vec())
        .collect()
}

fn flat_normal(m: &Mesh, f: usize) -> Vec3 {
    let p: Vec<Vec3> = m
        .faces
        .face(f)
        .iter()
        .map(|&v| m.positions[v as usize])
        .collect();
    (p[1] - p[0]).cross(p[2] - p[0]).normalize()
}

fn assert_hard_edges(m: &Mesh, what: &str) {
    assert_eq!(m.positions.len(), 8, "{what}: the cube's 8 vertices");
    for (f, corners) in corner_normals(m).iter().enumerate() {
        let flat = flat_normal(m, f);
        for n in corners {
            let angle = n.angle_between(flat).to_degrees();
            assert!(
                angle < 1e-2,
                "{what}: face {f}: {n} is {angle} degrees off {flat}"
            );
        }
    }
}

#[test]
fn a_cube_with_per_face_normals_keeps_its_hard_edges_through_obj_and_glb() {
    let mut m = read(&cube_obj()).expect("cube");
    assert_hard_edges(&m, "read");
    let read_corners = corner_normals(&m);
    // Deformed by nothing: the file's normals come back as they were.
    let same = m.positions.clone();
    m.move_vertices(same);
    assert_eq!(corner_normals(&m), read_corners);
    let obj = m.to_bytes(Format::Obj).expect("obj");
    let text = String::from_utf8(obj.clone()).expect("utf-8");
    assert_eq!(text.lines().filter(|l| l.starts_with("v ")).count(), 8);
    assert_eq!(text.lines().filter(|l| l.starts_with("vn ")).count(), 6);
    let back = Mesh::from_bytes(&obj, Format::Obj, Path::new("back.obj")).expect("back");
    assert_eq!(back.positions, m.positions);
    assert_eq!(corner_normals(&back), read_corners);
    for format in [Format::Glb, Format::Gltf] {
        let bytes = m.to_bytes(format).expect("glb");
        let back = Mesh::from_bytes(&bytes, format, Path::new("back.glb")).expect("back");
        assert_hard_edges(&back, "glb");
        // glTF keeps triangles: the faces' fans, over the same 8 vertices.
        let fans: Vec<u32> = m.faces.triangles().into_iter().flatten().collect();
        assert_eq!(back.faces.indices, fans, "{format:?}: welded back");
    }
}

#[test]
fn a_turned_and_stretched_cube_keeps_its_hard_edges_through_obj_and_glb() {
    let mut m = read(&cube_obj()).expect("cube");
    let r = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3);
    let moved: Vec<Vec3> = m
        .positions
        .iter()
        .map(|&p| r * (p * Vec3::new(2.0, 1.0, 0.5)))
        .collect();
    m.move_vertices(moved);
    assert_hard_edges(&m, "moved");
    for format in [Format::Obj, Format::Glb] {
        let bytes = m.to_bytes(format).expect("encode");
        let back = Mesh::from_bytes(&bytes, format, Path::new("back")).expect("back");
        assert_hard_edges(&back, &format!("{format:?}"));
    }
}

#[test]
fn a_smooth_sphere_with_vn_and_no_s_lines_keeps_its_smooth_normals() {
    let sphere = shapes::uv_sphere(1.0, 10, 16);
    // The true normals (not what csrbf would compute from the faces).
    let truth: Vec<Vec3> = sphere.positions.iter().map(|p| p.normalize()).collect();
    let mut s = String::new();
    for p in &sphere.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for n in &truth {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for f in sphere.faces.iter() {
        s.push('f');
        for v in f {
            let _ = write!(s, " {}//{}", v + 1, v + 1);
        }
        s.push('\n');
    }
    let mut m = read(&s).expect("sphere");
    assert_eq!(m.smoothing, None);
    assert_eq!(m.corner_normals, None, "one normal a vertex: no split");
    assert_eq!(m.normals.as_ref(), Some(&truth));
    let same = m.positions.clone();
    m.move_vertices(same);
    assert_eq!(m.normals.as_ref(), Some(&truth));
    let bytes = m.to_bytes(Format::Obj).expect("obj");
    let back = Mesh::from_bytes(&bytes, Format::Obj, Path::new("back.obj")).expect("back");
    assert_eq!(back.normals.as_ref(), Some(&truth));
    assert_eq!(back.corner_normals, None);
}

#[test]
fn faces_without_normal_indices_keep_computed_normals() {
    // No face names a normal: no normals, as before.
    let m = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 0 0\nf 1 2 3\n").expect("read");
    assert_eq!(m.normals, None);
    // One face names them, the other not: its own vertex gets the computed one.
    let m = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 1 0 0\nf 1//1 2//1 3//1\nf 2 4 3\n")
        .expect("read");
    let n = m.normals.expect("normals");
    assert_eq!(n[0], Vec3::X);
    assert!((n[3] - Vec3::Z).length() < 1e-6, "{}", n[3]);
}

#[test]
fn zero_length_and_non_finite_normals_are_read_as_no_normal() {
    for bad in ["0 0 0", "nan 0 1", "inf 0 0"] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn {bad}\nvn 0 0 1\nf 1//1 2//2 3//2\n");
        let m = read(&text).expect("read");
        let n = m.normals.expect("normals");
        assert!((n[0] - Vec3::Z).length() < 1e-6, "{bad}: computed {}", n[0]);
        assert_eq!(n[1], Vec3::Z);
        assert!(n.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn bad_normal_indices_name_the_file_and_line() {
    for (face, index) in [
        ("f 1//0 2//1 3//1", "0"),
        ("f 1//1 2//2 3//1", "2"),
        ("f 1//-3 2//1 3//1", "-3"),
    ] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n{face}\n");
        let err = read(&text).expect_err(face);
        assert!(
            matches!(err, MeshError::Parse { line: Some(5), .. }),
            "{err:?}"
        );
        let said = err.to_string();
        assert!(
            said.starts_with("n.obj:5: ")
                && said.contains(&format!("normal index {index} is out of range")),
            "{said}"
        );
    }
    let err = read("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//x 2//1 3//1\n").expect_err("x");
    assert!(
        err.to_string().starts_with("n.obj:5: normal index"),
        "{err}"
    );
}

#[test]
fn ply_and_off_say_they_lose_the_hard_edges() {
    let m = read(&cube_obj()).expect("cube");
    for format in [Format::Ply, Format::Off] {
        let said = format.loses(&m).expect("a loss");
        assert!(said.contains("hard edges"), "{said}");
    }
    assert_eq!(Format::Obj.loses(&m), None);
    assert_eq!(Format::Glb.loses(&m), None);
}

#[test]
fn normals_after_faces_without_them_land_on_their_own_corners() {
    // The first face names no normals, the next two do and disagree at
    // vertices 2 and 3: the per-corner normals line up with the corners.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 1 1 1\nf 1 2 3\nvn 0 0 1\nvn 1 0 0\n\
f 2//1 4//1 3//1\nf 2//2 5//2 4//2\n";
    let m = read(text).expect("read");
    let c = m.corner_normals.as_ref().expect("corner normals");
    assert_eq!(c.len(), 9);
    assert_eq!(
        &c[3..],
        &[Vec3::Z, Vec3::Z, Vec3::Z, Vec3::X, Vec3::X, Vec3::X]
    );
    let n = m.normals.as_ref().expect("normals");
    // Vertex 0 is only on the face without normals: computed, and its corner
    // takes it.
    assert!((n[0] - Vec3::Z).length() < 1e-6, "{}", n[0]);
    assert_eq!(c[0], n[0]);
    // Vertex 1 (index 1) has both: the normalised mean.
    assert!((n[1] - (Vec3::X + Vec3::Z).normalize()).length() < 1e-6);
}
