//! Faces that pass through each other (issue 23): in `deform`'s report and
//! `--json`, on by default, `--self-intersections off` to skip.

use crate::connected::hairpin;
use crate::support::*;

#[test]
fn an_arm_pushed_through_the_torso_is_reported() {
    let dir = TempDir::new("intersections");
    let (mesh, _) = hairpin(&dir);
    // The arm leg pushed across the gap, through the torso leg.
    let c = dir.write(
        "push.json",
        r#"{"radius": 0.5, "controls": [{"from": [0.2, -1.5, 0.5], "to": [-0.15, -1.5, 0.5]}]}"#,
    );
    let out = dir.path("out.obj");
    let run = |flag: &str| deform_json(&mesh, &c, &out, &["--self-intersections", flag]);
    let auto = run("auto");
    let n = auto["self_intersections"]
        .as_u64()
        .expect("looked for by default");
    assert!(n > 0, "{auto}");
    let pairs = auto["self_intersecting"].as_array().expect("pairs");
    assert_eq!(pairs.len() as u64, n.min(1000));
    assert!(pairs.iter().all(|p| p[0].as_u64() < p[1].as_u64()));
    assert!(
        auto["warnings"]
            .as_array()
            .is_some_and(|w| w.iter().any(|w| w
                .as_str()
                .is_some_and(|w| w.contains("pass through each other")))),
        "{auto}"
    );
    assert_eq!(run("on")["self_intersections"], auto["self_intersections"]);
    assert!(run("off")["self_intersections"].is_null());
    // A small move makes none.
    let small = dir.write(
        "small.json",
        r#"{"radius": 0.5, "controls": [{"from": [0.2, -1.5, 0.5], "to": [0.25, -1.5, 0.5]}]}"#,
    );
    let json = deform_json(&mesh, &small, &out, &[]);
    assert_eq!(json["self_intersections"], 0, "{json}");
    // A bad choice is clap's usage error (status 2), naming the flag.
    let bad = csrbf(&[
        "deform",
        "--mesh",
        arg(&mesh),
        "--controls",
        arg(&c),
        "--out",
        arg(&out),
        "--self-intersections",
        "maybe",
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--self-intersections"));
}
