//! Issue 25 (a new user's OBJ trial): an OBJ's materials and textures are
//! read from its library and kept into any folder and through glTF; side
//! files that csrbf did not write are left alone unless forced; smoothing
//! groups survive.

use std::path::{Path, PathBuf};

use csrbf::synthetic::Rng;

use crate::{Format, Mesh, WriteOptions};

/// A fresh temporary folder, removed on drop.
struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("csrbf-objmtl-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("in")).expect("dir");
        std::fs::create_dir_all(d.join("out")).expect("dir");
        Dir(d)
    }
    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A PNG's signature and seeded bytes: the mesh crate only looks at the
/// signature and keeps the bytes.
fn png(seed: u64) -> Vec<u8> {
    let mut rng = Rng::new(seed);
    let mut b = b"\x89PNG\r\n\x1a\n".to_vec();
    b.extend((0..64).map(|_| rng.below(256) as u8));
    b
}

const DUCK: &str = "mtllib duck.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n\
usemtl blinn3\ns off\nf 1/1 2/2 3/3\ns 1\nf 2/2 4/4 3/3\n";
const DUCK_MTL: &str =
    "newmtl blinn3\nKd 0.2 0.4 0.6\nKs 0.5 0.5 0.5\nd 0.75\nmap_Kd duck_tex.png\n";

/// The duck of the report in `in/`: duck.obj, duck.mtl, duck_tex.png.
fn duck(d: &Dir) -> PathBuf {
    std::fs::write(d.path("in/duck.obj"), DUCK).expect("obj");
    std::fs::write(d.path("in/duck.mtl"), DUCK_MTL).expect("mtl");
    std::fs::write(d.path("in/duck_tex.png"), png(1)).expect("png");
    d.path("in/duck.obj")
}

/// A material's name, colour and texture.
type Look = (String, [f32; 4], Option<(String, Vec<u8>)>);

/// What both an OBJ library and glTF carry of materials: names, colours and
/// base-colour textures (glTF's sampler, roughness or alpha mode do not
/// pass through an OBJ, and an OBJ's defaults are not glTF's).
fn looks(materials: &[crate::Material]) -> Vec<Look> {
    materials
        .iter()
        .map(|m| (m.name.clone(), m.color, m.texture.clone()))
        .collect()
}

fn line(file: &Path, key: &str) -> Option<String> {
    std::fs::read_to_string(file)
        .expect("file")
        .lines()
        .find_map(|l| l.strip_prefix(key).map(str::to_owned))
}

#[test]
fn obj_reads_its_library_colour_alpha_and_texture() {
    let d = Dir::new("read");
    let loaded = crate::load(&duck(&d)).expect("load");
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    let m = &loaded.mesh.materials;
    assert_eq!(m.len(), 1);
    assert_eq!(m[0].name, "blinn3");
    assert_eq!(m[0].color, [0.2, 0.4, 0.6, 0.75]);
    assert_eq!(m[0].texture, Some(("image/png".to_owned(), png(1))));
}

/// The report's first case: deformed into another folder, the duck's
/// library said `Kd 0.8 0.8 0.8` and had no texture.
#[test]
fn obj_to_obj_in_another_folder_keeps_colours_and_textures() {
    let d = Dir::new("obj-obj");
    let mesh = crate::read(&duck(&d)).expect("read");
    let out = d.path("out/d.obj");
    let written = crate::write_with(&out, &mesh, &WriteOptions::default()).expect("write");
    assert_eq!(
        written.files,
        vec![out.clone(), d.path("out/d.mtl"), d.path("out/d_0.png")]
    );
    assert!(written.warnings.is_empty(), "{:?}", written.warnings);
    assert_eq!(line(&out, "mtllib ").as_deref(), Some("d.mtl"));
    assert_eq!(
        line(&d.path("out/d.mtl"), "Kd ").as_deref(),
        Some("0.2 0.4 0.6")
    );
    let back = crate::load(&out).expect("read back");
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!(back.mesh.materials, mesh.materials);
    // And again from there into a third folder (an OBJ csrbf wrote).
    std::fs::create_dir_all(d.path("again")).expect("dir");
    let again = d.path("again/e.obj");
    crate::write(&again, &back.mesh).expect("write");
    assert_eq!(crate::read(&again).expect("read").materials, mesh.materials);
}

/// Beside its own library, an output names it (keeping what csrbf does not
/// read, like `Ks`) instead of writing a copy.
#[test]
fn obj_beside_its_library_names_it() {
    let d = Dir::new("beside");
    let mesh = crate::read(&duck(&d)).expect("read");
    let out = d.path("in/smile.obj");
    let written = crate::write_with(&out, &mesh, &WriteOptions::default()).expect("write");
    assert_eq!(written.files, vec![out.clone()]);
    assert_eq!(line(&out, "mtllib ").as_deref(), Some("duck.mtl"));
    assert!(!d.path("in/smile.mtl").exists());
    assert_eq!(crate::read(&out).expect("read").materials, mesh.materials);
}

#[test]
fn obj_to_glb_keeps_colours_and_textures() {
    let d = Dir::new("obj-glb");
    let mesh = crate::read(&duck(&d)).expect("read");
    let out = d.path("out/d.glb");
    crate::write(&out, &mesh).expect("write");
    let back = crate::read(&out).expect("read back");
    assert_eq!(looks(&back.materials), looks(&mesh.materials));
}

/// The report: an OBJ csrbf wrote from BoxTextured.glb lost its texture
/// when deformed again into another folder.
#[test]
fn glb_to_obj_to_obj_keeps_colours_and_textures() {
    let d = Dir::new("glb-obj-obj");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/models");
    let glb = crate::read(&root.join("assimp_BoxTextured.glb")).expect("box");
    assert!(glb.materials.iter().any(|m| m.texture.is_some()));
    let first = d.path("in/b.obj");
    crate::write(&first, &glb).expect("write");
    let obj = crate::load(&first).expect("read");
    assert!(obj.warnings.is_empty(), "{:?}", obj.warnings);
    assert_eq!(looks(&obj.mesh.materials), looks(&glb.materials));
    let second = d.path("out/c.obj");
    crate::write(&second, &obj.mesh).expect("write");
    assert_eq!(
        looks(&crate::read(&second).expect("read").materials),
        looks(&glb.materials)
    );
    let third = d.path("out/c.glb");
    crate::write(&third, &obj.mesh).expect("write");
    assert_eq!(
        looks(&crate::read(&third).expect("read").materials),
        looks(&glb.materials)
    );
}

/// A missing library or texture, a texture that is neither PNG nor JPEG,
/// and paths out of the model's folder: the mesh loads, each said by name.
#[test]
fn missing_foreign_or_escaping_side_files_are_warnings() {
    let d = Dir::new("missing");
    let obj = d.path("in/m.obj");
    let body = "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    let load = |mtllib: &str| {
        std::fs::write(&obj, format!("mtllib {mtllib}\n{body}")).expect("obj");
        crate::load(&obj).expect("loads all the same")
    };
    let l = load("gone.mtl");
    assert!(l.mesh.materials.is_empty());
    assert!(
        l.warnings.len() == 1 && l.warnings[0].contains("gone.mtl"),
        "{:?}",
        l.warnings
    );
    let many: Vec<String> = (0..1000).map(|k| format!("m{k}.mtl")).collect();
    let l = load(&many.join(" "));
    assert!(l.warnings.len() <= 20, "{}", l.warnings.len());
    assert!(
        l.warnings[0].contains("only the first 16"),
        "{:?}",
        l.warnings
    );
    std::fs::write(d.path("secret.mtl"), "newmtl a\nKd 1 0 0\n").expect("mtl");
    for bad in ["../secret.mtl", "/etc/passwd", "C:/x.mtl"] {
        let l = load(bad);
        assert!(l.mesh.materials.is_empty(), "{bad}");
        assert!(l.warnings[0].contains("refused"), "{bad}: {:?}", l.warnings);
    }
    std::fs::write(d.path("secret.png"), png(2)).expect("png");
    std::fs::write(d.path("in/tex.tga"), b"not a png").expect("tga");
    std::fs::write(
        d.path("in/m.mtl"),
        "newmtl a\nKd 1 0 0\nmap_Kd ../secret.png\nnewmtl b\nKd 0 1 0\nmap_Kd tex.tga\nnewmtl c\nmap_Kd none.png\n",
    )
    .expect("mtl");
    let l = load("m.mtl");
    assert_eq!(l.mesh.materials.len(), 3);
    assert!(l.mesh.materials.iter().all(|m| m.texture.is_none()));
    assert_eq!(l.mesh.materials[0].color, [1.0, 0.0, 0.0, 1.0]);
    let said = l.warnings.join("\n");
    assert!(said.contains("\"../secret.png\" is refused"), "{said}");
    assert!(said.contains("tex.tga is neither PNG nor JPEG"), "{said}");
    assert!(said.contains("none.png"), "{said}");
    // A symlink in the model's folder that points out of it is refused too.
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(d.path("secret.mtl"), d.path("in/linked.mtl")).expect("link");
        std::os::unix::fs::symlink(d.path("secret.png"), d.path("in/linked.png")).expect("link");
        let l = load("linked.mtl");
        assert!(l.mesh.materials.is_empty(), "{:?}", l.mesh.materials);
        assert!(
            l.warnings[0].contains("\"linked.mtl\" is refused"),
            "{:?}",
            l.warnings
        );
        std::fs::write(
            d.path("in/m.mtl"),
            "newmtl a\nKd 1 0 0\nmap_Kd linked.png\n",
        )
        .expect("mtl");
        let l = load("m.mtl");
        assert!(l.mesh.materials[0].texture.is_none());
        assert!(
            l.warnings.join("\n").contains("\"linked.png\" is refused"),
            "{:?}",
            l.warnings
        );
        // A named pipe is no texture: refused, not read (reading it would
        // wait for a writer forever).
        let fifo = d.path("in/pipe.png");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .expect("mkfifo");
        assert!(made.success());
        std::fs::write(d.path("in/m.mtl"), "newmtl a\nKd 1 0 0\nmap_Kd pipe.png\n").expect("mtl");
        let l = load("m.mtl");
        assert!(l.mesh.materials[0].texture.is_none());
        assert!(
            l.warnings.join("\n").contains("\"pipe.png\" is refused"),
            "{:?}",
            l.warnings
        );
    }
}

/// The report's second case: an unrelated b_0.png was replaced, and a
/// b.mtl csrbf did not write made the OBJ lose its library without a word.
#[test]
fn side_files_csrbf_did_not_write_are_left_alone_unless_forced() {
    let d = Dir::new("side");
    let mesh = crate::read(&duck(&d)).expect("read");
    let out = d.path("out/b.obj");
    std::fs::write(d.path("out/b_0.png"), b"the user's picture").expect("png");
    let w = crate::write_with(&out, &mesh, &WriteOptions::default()).expect("write");
    assert_eq!(
        std::fs::read(d.path("out/b_0.png")).expect("png"),
        b"the user's picture"
    );
    assert!(
        w.warnings.len() == 1
            && w.warnings[0].contains("b_0.png")
            && w.warnings[0].contains("--force"),
        "{:?}",
        w.warnings
    );
    assert_eq!(line(&d.path("out/b.mtl"), "map_Kd "), None);
    assert_eq!(w.files, vec![out.clone(), d.path("out/b.mtl")]);
    // Forced: replaced; our own b.mtl (with its header) is replaced freely.
    let w =
        crate::write_with(&out, &mesh, &WriteOptions::default().with_force(true)).expect("write");
    assert!(w.warnings.is_empty(), "{:?}", w.warnings);
    assert_eq!(std::fs::read(d.path("out/b_0.png")).expect("png"), png(1));
    // The same bytes already there: no warning, nothing to force.
    let w = crate::write_with(&out, &mesh, &WriteOptions::default()).expect("write");
    assert!(w.warnings.is_empty(), "{:?}", w.warnings);
    assert_eq!(crate::read(&out).expect("read").materials, mesh.materials);
    // A library csrbf did not write: left alone, said, no mtllib.
    std::fs::write(d.path("out/b.mtl"), "newmtl mine\n").expect("mtl");
    let w = crate::write_with(&out, &mesh, &WriteOptions::default()).expect("write");
    assert_eq!(
        std::fs::read_to_string(d.path("out/b.mtl")).expect("mtl"),
        "newmtl mine\n"
    );
    assert_eq!(line(&out, "mtllib "), None);
    assert!(
        w.warnings.len() == 1
            && w.warnings[0].contains("b.mtl")
            && w.warnings[0].contains("blinn3")
            && w.warnings[0].contains("--force"),
        "{:?}",
        w.warnings
    );
    crate::write_with(&out, &mesh, &WriteOptions::default().with_force(true)).expect("write");
    assert_eq!(line(&out, "mtllib ").as_deref(), Some("b.mtl"));
    assert_eq!(crate::read(&out).expect("read").materials, mesh.materials);
}

/// Whole or not at all across files: one that cannot be written leaves
/// the others unwritten too.
#[test]
fn several_files_are_written_all_or_none() {
    let d = Dir::new("atomic");
    let a = d.path("out/a.txt");
    let b = d.path("nowhere/b.txt");
    assert!(crate::write_all_atomic(&[(&a, b"a"), (&b, b"b")]).is_err());
    assert!(!a.exists());
    let left: Vec<_> = std::fs::read_dir(d.path("out")).expect("dir").collect();
    assert!(left.is_empty(), "temporaries left: {left:?}");
}

/// The report's third case: pybullet_duck.obj's `s 1` was dropped, so
/// Blender shaded every face flat.
#[test]
fn smoothing_groups_survive_obj_to_obj() {
    let d = Dir::new("smooth");
    let mesh = crate::read(&duck(&d)).expect("read");
    assert_eq!(mesh.smoothing, Some(vec![0, 1]));
    let out = d.path("out/s.obj");
    crate::write(&out, &mesh).expect("write");
    let text = std::fs::read_to_string(&out).expect("obj");
    let s_lines: Vec<&str> = text.lines().filter(|l| l.starts_with("s ")).collect();
    assert_eq!(s_lines, ["s 1"], "{text}");
    assert_eq!(crate::read(&out).expect("read").smoothing, mesh.smoothing);
    // No `s` in the file: none written (faces stay flat, as they were).
    let flat = Mesh::from_bytes(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        Format::Obj,
        "f.obj".as_ref(),
    )
    .expect("parse");
    assert_eq!(flat.smoothing, None);
    let text = String::from_utf8(flat.to_bytes(Format::Obj).expect("obj")).expect("text");
    assert!(!text.contains("\ns "), "{text}");
}
