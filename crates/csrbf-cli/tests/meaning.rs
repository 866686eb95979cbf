//! One meaning for every file (issue 6): a control file of several
//! deformations gives the same positions in `deform`, `fit` + `apply` and the
//! scenes `render` draws, chained or added, with stage phases and `--phase`.

use crate::support::*;

fn two(combine: &str) -> String {
    format!(
        r#"{{"combine": "{combine}", "deformations": [
          {{"radius": 4, "controls": [{{"from": [2.15, 10.18, 4.42], "to": [2.15, 11.5, 5.0]}}]}},
          {{"radius": 3, "phase": 0.6, "region": {{"box": {{"min": [-9, 11, -9], "max": [9, 20, 9]}}, "falloff": 1.5}},
           "controls": [{{"from": [2.3, 11.2, 4.6], "to": [3.2, 11.2, 4.6]}}]}}]}}"#
    )
}

#[test]
fn deform_and_apply_agree_for_chained_and_added_files() {
    let dir = TempDir::new("meaning");
    let head = model("cgal_head.off");
    let mut results = Vec::new();
    for combine in ["chain", "add"] {
        let c = dir.write(&format!("{combine}.json"), two(combine));
        let deformed = dir.path(&format!("{combine}_deform.ply"));
        let fitted = dir.path(&format!("{combine}.csrbf"));
        let applied = dir.path(&format!("{combine}_apply.ply"));
        ok(&[
            "deform",
            "-q",
            "--mesh",
            arg(&head),
            "--controls",
            arg(&c),
            "--phase",
            "0.7",
            "--out",
            arg(&deformed),
        ]);
        ok(&["fit", "-q", "--controls", arg(&c), "--out", arg(&fitted)]);
        ok(&[
            "apply",
            "-q",
            "--mesh",
            arg(&head),
            "--deformation",
            arg(&fitted),
            "--phase",
            "0.7",
            "--out",
            arg(&applied),
        ]);
        let a = csrbf_mesh::read(&deformed).expect("deformed");
        let b = csrbf_mesh::read(&applied).expect("applied");
        assert_eq!(
            a.positions, b.positions,
            "{combine}: apply differs from deform"
        );
        let info = ok(&["info", "--deformation", arg(&fitted), "--json"]);
        assert!(
            info.contains(&format!("\"combine\": \"{combine}\"")),
            "{info}"
        );
        assert!(info.contains("\"phase\": 0.6"), "{info}");
        results.push(a.positions);
    }
    assert_ne!(results[0], results[1], "chain and add should differ here");
}

#[test]
fn export_says_how_a_chain_is_represented_and_bad_combines_are_named() {
    let dir = TempDir::new("meaning-export");
    std::fs::copy(model("cgal_head.off"), dir.path("head.off")).expect("copy");
    dir.write("two.json", two("chain"));
    let scene = dir.write(
        "s.scene.json",
        r#"{"duration": 1, "camera": {"eye": [-30, 10, 10], "target": [0, 9, 0]},
            "objects": [{"name": "head", "mesh": "head.off",
              "parts": [{"name": "skin", "deformations": [{"controls": "two.json"}]}]}]}"#,
    );
    let out = dir.path("s.glb");
    let r = csrbf(&["export", arg(&scene), "--out", arg(&out)]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(r.status.success(), "{err}");
    assert!(
        err.contains("chained") && err.contains("one morph target"),
        "{err}"
    );
    let bad = dir.write("bad.json", two("blend"));
    fails(
        &[
            "deform",
            "--mesh",
            arg(&dir.path("head.off")),
            "--controls",
            arg(&bad),
            "--out",
            arg(&dir.path("o.obj")),
        ],
        &["bad.json", "combine", "expected chain or add"],
    );
    assert!(!dir.path("o.obj").exists());
}
