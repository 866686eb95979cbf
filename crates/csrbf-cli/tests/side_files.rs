//! Issue 25: an OBJ's materials, textures and smoothing through the CLI,
//! and side files that csrbf did not write left alone unless `--force`.

use crate::support::*;

/// Deforms `mesh` into `out` with `extra` flags; must succeed; standard error.
fn deform(dir: &TempDir, mesh: &std::path::Path, out: &str, extra: &[&str]) -> String {
    let c = dir.write("c.json", controls_for(mesh, "c2", "none"));
    let out = dir.path(out);
    let mut args = vec![
        "deform",
        "--mesh",
        arg(mesh),
        "--controls",
        arg(&c),
        "--out",
        arg(&out),
    ];
    args.extend_from_slice(extra);
    let r = csrbf(&args);
    let err = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(r.status.success(), "{args:?}: {err}");
    err
}

/// A PNG's signature and a few bytes (only the signature is looked at).
const PNG: &[u8] = b"\x89PNG\r\n\x1a\n-a-tiny-duck-texture-";

/// The report's first and third cases: the duck's library and texture were
/// lost in another folder and in GLB, its `s 1` everywhere.
#[test]
fn the_duck_keeps_its_colour_texture_and_smoothing_in_another_folder() {
    let dir = TempDir::new("duck-mtl");
    let duck = dir.write(
        "duck.obj",
        std::fs::read(model("pybullet_duck.obj")).expect("duck"),
    );
    dir.write(
        "duck.mtl",
        "newmtl blinn3\nKd 0.2 0.4 0.6\nmap_Kd duck_tex.png\n",
    );
    dir.write("duck_tex.png", PNG);
    std::fs::create_dir_all(dir.path("other")).expect("dir");
    let err = deform(&dir, &duck, "other/d.obj", &[]);
    assert!(
        !err.contains("duck.mtl") && !err.contains("left alone"),
        "{err}"
    );
    assert!(err.contains("d.obj, d.mtl, d_0.png"), "{err}");
    let mtl = std::fs::read_to_string(dir.path("other/d.mtl")).expect("mtl");
    assert!(
        mtl.contains("Kd 0.2 0.4 0.6") && mtl.contains("map_Kd d_0.png"),
        "{mtl}"
    );
    assert_eq!(std::fs::read(dir.path("other/d_0.png")).expect("png"), PNG);
    let obj = std::fs::read_to_string(dir.path("other/d.obj")).expect("obj");
    assert!(obj.lines().any(|l| l == "s 1"), "no smoothing written");
    deform(&dir, &duck, "other/d.glb", &[]);
    let glb = csrbf_mesh::read(&dir.path("other/d.glb")).expect("glb");
    assert_eq!(glb.materials.len(), 1);
    assert_eq!(glb.materials[0].color, [0.2, 0.4, 0.6, 1.0]);
    assert_eq!(
        glb.materials[0].texture.as_ref().map(|t| t.1.as_slice()),
        Some(PNG)
    );
    // Without its library the duck still deforms, and the warning names it.
    std::fs::remove_file(dir.path("duck.mtl")).expect("rm");
    let err = deform(&dir, &duck, "other/e.obj", &[]);
    assert!(err.contains("warning") && err.contains("duck.mtl"), "{err}");
    let info = csrbf(&["info", "--mesh", arg(&duck)]);
    let said = String::from_utf8_lossy(&info.stderr);
    assert!(info.status.success() && said.contains("duck.mtl"), "{said}");
}

/// The report's second case: an unrelated b_0.png was replaced without a
/// word, and a b.mtl csrbf did not write left b.obj without a library.
#[test]
fn side_files_csrbf_did_not_write_need_force() {
    let dir = TempDir::new("side-files");
    let boxed = model("assimp_BoxTextured.glb");
    dir.write("b_0.png", "the user's picture");
    let err = deform(&dir, &boxed, "b.obj", &[]);
    assert_eq!(
        std::fs::read(dir.path("b_0.png")).expect("png"),
        b"the user's picture"
    );
    assert!(
        err.contains("warning") && err.contains("b_0.png") && err.contains("--force"),
        "{err}"
    );
    assert!(err.contains("b.obj, b.mtl\n"), "{err}");
    let err = deform(&dir, &boxed, "b.obj", &["--force"]);
    assert!(!err.contains("left alone"), "{err}");
    assert!(err.contains("b.obj, b.mtl, b_0.png"), "{err}");
    assert_ne!(
        std::fs::read(dir.path("b_0.png")).expect("png"),
        b"the user's picture"
    );
    // Someone else's b.mtl.
    dir.write("b.mtl", "newmtl theirs\n");
    let err = deform(&dir, &boxed, "b.obj", &[]);
    assert!(
        err.contains("b.mtl")
            && err.contains("names no material library")
            && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path("b.mtl")).expect("mtl"),
        "newmtl theirs\n"
    );
    deform(&dir, &boxed, "b.obj", &["--force"]);
    let back = csrbf_mesh::read(&dir.path("b.obj")).expect("b.obj");
    let glb = csrbf_mesh::read(&boxed).expect("glb");
    // What an OBJ's library carries of a material: its colour and texture
    // (not glTF's sampler, roughness or alpha mode).
    let said = |m: &csrbf_mesh::Material| (m.name.clone(), m.color, m.texture.clone());
    assert_eq!(
        back.materials.iter().map(said).collect::<Vec<_>>(),
        glb.materials.iter().map(said).collect::<Vec<_>>()
    );
}
