//! Stretched faces (issue 23) in `deform`'s report and `--json`, with
//! `--stretch-limit`, and in `apply`.

use crate::support::*;

#[test]
fn stretched_faces_are_listed_and_the_limit_is_checked() {
    let dir = TempDir::new("stretch");
    let head = model("cgal_head.off");
    // A long pull with a small radius: a spike.
    let c = dir.write(
        "pull.json",
        r#"{"radius": 3, "controls": [{"from": [2.15, 10.18, 4.42], "to": [2.15, 10.18, 12.0]}]}"#,
    );
    let out = dir.path("out.ply");
    let run = |limit: &str| deform_json(&head, &c, &out, &["--stretch-limit", limit]);
    let four = run("4");
    let two = run("2");
    let largest = four["largest_stretch"].as_f64().expect("largest_stretch");
    assert!(largest > 4.0, "{four}");
    assert_eq!(four["stretch_limit"], 4.0);
    let n4 = four["stretched_faces"].as_u64().expect("count");
    let n2 = two["stretched_faces"].as_u64().expect("count");
    assert!(n4 > 0 && n2 > n4, "{n4} {n2}");
    assert_eq!(
        four["stretched"].as_array().map(Vec::len),
        Some(n4 as usize)
    );
    assert!(four["largest_stretch_face"].is_u64());
    assert!(
        four["warnings"]
            .as_array()
            .is_some_and(|w| w.iter().any(|w| w
                .as_str()
                .is_some_and(|w| w.contains("stretched more than 4x")))),
        "{four}"
    );
    // The same figures after fit + apply.
    let fitted = dir.path("pull.csrbf");
    ok(&["fit", "-q", "--controls", arg(&c), "--out", arg(&fitted)]);
    let applied = ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&head),
        "--deformation",
        arg(&fitted),
        "--out",
        arg(&dir.path("a.ply")),
        "--json",
    ]);
    let applied: serde_json::Value = serde_json::from_str(&applied).expect("json");
    assert_eq!(applied["stretched_faces"], four["stretched_faces"]);
    // A limit that is no limit is named.
    for bad in ["0.5", "nan", "inf"] {
        fails(
            &[
                "deform",
                "--mesh",
                arg(&head),
                "--controls",
                arg(&c),
                "--out",
                arg(&out),
                "--stretch-limit",
                bad,
            ],
            &["--stretch-limit", "finite number >= 1"],
        );
    }
}
