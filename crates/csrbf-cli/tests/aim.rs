//! Aiming and trusting an edit (issue 6): camera flags, `pick` against the
//! picture `render` draws, handles on a real model, diagnostics.

use serde_json::Value;

use crate::pictures::image_rgba;
use crate::support::*;

fn json(args: &[&str]) -> Value {
    serde_json::from_str(&ok(args)).expect("JSON on standard output")
}

#[test]
fn pick_finds_what_render_draws_at_that_pixel() {
    let dir = TempDir::new("pick");
    let head = model("cgal_head.off");
    // Perspective and orthographic: both go through the one camera.
    for (k, flags) in [
        vec!["--view", "front", "--size", "160x120", "--zoom", "1.2"],
        vec!["--view", "left", "--size", "160x120", "--ortho"],
    ]
    .into_iter()
    .enumerate()
    {
        let shot = dir.path(&format!("shot{k}.png"));
        let mut args = vec!["render", "-q", "--mesh", arg(&head), "--out", arg(&shot)];
        args.extend(flags.iter().copied());
        ok(&args);
        let (w, h, px) = image_rgba(&shot);
        assert_eq!((w, h), (160, 120));
        let background = px[0];
        let mut hits = 0;
        for (x, y) in [
            (80, 60),
            (0, 0),
            (159, 119),
            (70, 30),
            (95, 90),
            (40, 60),
            (120, 60),
        ] {
            let pixel = format!("{x},{y}");
            let mut args = vec![
                "pick",
                "-q",
                "--mesh",
                arg(&head),
                "--pixel",
                &pixel,
                "--json",
            ];
            args.extend(flags.iter().copied());
            let v = json(&args);
            let drawn = px[(y * w + x) as usize] != background;
            assert_eq!(
                v["hit"] == true,
                drawn,
                "{flags:?} pixel {pixel}: pick {v} vs picture"
            );
            if drawn {
                hits += 1;
                // The rest point lies on the mesh's triangle (no controls: equals the point).
                let p = &v["point"];
                let r = &v["rest_point"];
                for k in 0..3 {
                    let (a, b) = (p[k].as_f64().expect("x"), r[k].as_f64().expect("x"));
                    assert!((a - b).abs() < 1e-4, "{p} vs {r}");
                }
            }
        }
        assert!(
            hits >= 3,
            "{flags:?}: the head should cover the middle of the picture"
        );
    }
}

#[test]
fn a_handle_turns_suzannes_ear_as_a_rigid_body_without_folding() {
    let dir = TempDir::new("ear");
    let suzanne = model("assimp_Suzanne_248.obj");
    let pivot = [0.9, 0.85, -0.3];
    let controls = dir.write(
        "ear.json",
        serde_json::json!({
            "kernel": "c2", "radius": 0.8,
            "handle": {"select": {"box": {"min": [1.1, -2, -2], "max": [2, 2, 2]}},
                       "rotate": {"axis": [0, 1, 0], "angle_deg": 90, "pivot": pivot}},
            "anchor": {"box": {"min": [-2, -2, -2], "max": [0.6, 2, 2]}}
        })
        .to_string(),
    );
    let out = dir.path("ear.obj");
    let v = json(&[
        "deform",
        "-q",
        "--mesh",
        arg(&suzanne),
        "--controls",
        arg(&controls),
        "--out",
        arg(&out),
        "--json",
    ]);
    assert_eq!(v["flipped_faces"], 0, "{v}");
    let a = csrbf_mesh::read(&suzanne).expect("in");
    // Issue 17: as a single map, a 90-degree bend over a gap of R/2
    // squeezed its inner side inside out at a few faces near the end of the
    // turn; whatever folds may only be there: not in the ear, not in the head.
    let inside_out: Vec<u64> = v["inside_out"]
        .as_array()
        .expect("inside_out")
        .iter()
        .map(|t| t.as_u64().expect("index"))
        .collect();
    assert!(inside_out.len() <= 10, "{v}");
    let triangles = a.faces.triangles();
    for &t in &inside_out {
        let c = triangles[t as usize]
            .iter()
            .map(|&i| a.positions[i as usize].x)
            .sum::<f32>()
            / 3.0;
        assert!(
            (0.6..1.1).contains(&c),
            "triangle {t} at x = {c}, outside the bend"
        );
    }
    if !inside_out.is_empty() {
        assert!(v["fold_phase"].as_f64().expect("fold phase") > 0.75, "{v}");
    }
    // A folded bend also passes through itself (issue 23): the only other warning.
    let warnings = v["warnings"].as_array().expect("warnings");
    assert!(
        warnings.iter().all(|w| w
            .as_str()
            .is_some_and(|w| w.contains("inside out") || w.contains("pass through each other"))),
        "{v}"
    );
    let b = csrbf_mesh::read(&out).expect("out");
    // The ear's tip (the centroid of its outermost vertices, not samples).
    let tip: Vec<usize> = (0..a.positions.len())
        .filter(|&i| a.positions[i].x >= 1.3)
        .collect();
    let centre = |m: &csrbf_mesh::Mesh| {
        tip.iter().map(|&i| m.positions[i]).sum::<glam::Vec3>() / tip.len() as f32
    };
    let p = glam::Vec3::from_array(pivot.map(|x| x as f32));
    let (u, w) = (centre(&a) - p, centre(&b) - p);
    // Turned about +Y: angle in the XZ plane, length kept.
    let angle = (u.z * w.x - u.x * w.z)
        .atan2(u.x * w.x + u.z * w.z)
        .to_degrees();
    assert!((angle - 90.0).abs() < 2.0, "tip turned {angle} degrees");
    assert!(
        (w.length() / u.length() - 1.0).abs() < 0.03,
        "length {} -> {}",
        u.length(),
        w.length()
    );
    // Issue 42: the ear (x >= 1.1) turns as a rigid body, exactly: every
    // vertex where the turn puts it. A 90-degree turn over a gap of R/2
    // passes the fold-free bound, so it is a sweep by itself: nothing folds.
    assert!(inside_out.is_empty(), "{v}");
    let turn = glam::Quat::from_axis_angle(glam::Vec3::Y, 90f32.to_radians());
    for (r, m) in a.positions.iter().zip(&b.positions) {
        if r.x >= 1.1 {
            let want = p + turn * (*r - p);
            assert!(m.distance(want) < 1e-4, "{r} -> {m}, not {want}");
        }
    }
    // The anchor (x <= 0.6) stays nearly put, and what lies farther than R
    // from every vector, pins included (x < -0.5), does not move at all.
    for (i, (r, m)) in a.positions.iter().zip(&b.positions).enumerate() {
        if r.x < -0.5 {
            assert!(r.distance(*m) < 1e-6, "vertex {i} moved {}", r.distance(*m));
        } else if r.x <= 0.6 {
            assert!(
                r.distance(*m) < 0.02,
                "anchor vertex {i} moved {}",
                r.distance(*m)
            );
        }
    }
    // `fit` stores the handle's vectors like any others; `apply` replays them.
    let fitted = dir.path("ear.csrbf");
    ok(&[
        "fit",
        "-q",
        "--controls",
        arg(&controls),
        "--mesh",
        arg(&suzanne),
        "--out",
        arg(&fitted),
    ]);
    let replay = dir.path("replay.obj");
    ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&suzanne),
        "--deformation",
        arg(&fitted),
        "--out",
        arg(&replay),
    ]);
    let c = csrbf_mesh::read(&replay).expect("replay");
    for (x, y) in b.positions.iter().zip(&c.positions) {
        assert!(x.distance(*y) < 1e-5);
    }
}

#[test]
fn deform_reports_moves_folds_and_leaks() {
    let dir = TempDir::new("diag");
    let head = model("cgal_head.off");
    let smile = root().join("assets/controls/head_smile.json");
    let out = dir.path("smile.obj");
    let v = json(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&smile),
        "--out",
        arg(&out),
        "--json",
    ]);
    assert!(v["moved"].as_u64().expect("moved") > 100);
    assert_eq!(v["flipped_faces"], 0);
    assert_eq!(v["warnings"].as_array().map(Vec::len), Some(0), "{v}");
    // The papers' linear polynomial moves the back of the head too: said.
    let text = std::fs::read_to_string(&smile)
        .expect("smile")
        .replace("\"none\"", "\"linear\"");
    let linear = dir.write("linear.json", text);
    let v = json(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&linear),
        "--out",
        arg(&out),
        "--force",
        "--json",
    ]);
    let warnings = v["warnings"].to_string();
    assert!(
        warnings.contains("linear polynomial made a local edit global"),
        "{warnings}"
    );
    // A shove far past the fold-free bound folds the surface: said, with the faces.
    let fold = dir.write(
        "fold.json",
        r#"{"radius": 2, "controls": [{"from": [0.9, 12.9, 4.5], "to": [0.9, 10.5, 4.5]}]}"#,
    );
    let v = json(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&fold),
        "--out",
        arg(&out),
        "--force",
        "--json",
    ]);
    assert!(v["flipped_faces"].as_u64().expect("flipped") > 0, "{v}");
    assert!(v["warnings"].to_string().contains("fold-free bound"), "{v}");
}

#[test]
fn bad_aims_and_handles_are_named() {
    let dir = TempDir::new("badaim");
    let head = model("cgal_head.off");
    let h = arg(&head);
    let png = dir.path("x.png");
    let p = arg(&png);
    fails(
        &["pick", "--mesh", h, "--pixel", "2000,10"],
        &["--pixel", "outside the 1024x768 picture"],
    );
    fails(
        &["pick", "--mesh", h, "--pixel", "ten,10"],
        &["--pixel", "expected X,Y"],
    );
    fails(
        &[
            "render", "--mesh", h, "--out", p, "--eye", "1,2,3", "--target", "1,2,3",
        ],
        &["camera", "must be finite and distinct"],
    );
    fails(
        &[
            "render", "--mesh", h, "--out", p, "--eye", "0,9,0", "--target", "0,0,0", "--up", "y",
        ],
        &["camera", "not parallel"],
    );
    fails(
        &["render", "--mesh", h, "--out", p, "--view", "sideways"],
        &["--view", "unknown view"],
    );
    fails(
        &["render", "--mesh", h, "--out", p, "--up", "w"],
        &["--up", "unknown axis"],
    );
    fails(
        &["render", "--mesh", h, "--out", p, "--overlay"],
        &["--overlay", "--controls"],
    );
    fails(
        &["render", "--mesh", h, "--out", p, "--eye", "1,nan,3"],
        &["--eye", "three finite numbers"],
    );
    assert!(!png.exists());
    let out = dir.path("o.obj");
    let o = arg(&out);
    let cases = [
        (
            r#"{"radius": 2, "handle": {"select": {"group": "x"}, "rotate": {"axis": [0, 0, 0], "angle_deg": 9}}}"#,
            "handle.rotate.axis",
        ),
        (
            r#"{"radius": 2, "handle": {"select": {"box": {"min": [90, 90, 90], "max": [91, 91, 91]}}, "scale": 2}}"#,
            "holds none of the 1487 points",
        ),
        (
            r#"{"radius": 2, "handle": {"select": {"sphere": {"center": [2.15, 10.18, 4.42], "radius": 1}}, "scale": 2}, "anchor": {"sphere": {"center": [2.15, 10.18, 4.42], "radius": 2}}}"#,
            "share",
        ),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let c = dir.write(&format!("c{i}.json"), text);
        fails(
            &["deform", "--mesh", h, "--controls", arg(&c), "--out", o],
            &[want],
        );
        assert!(!out.exists());
    }
    let c = dir.write("handle.json", cases[1].0);
    fails(
        &[
            "fit",
            "--controls",
            arg(&c),
            "--out",
            arg(&dir.path("f.csrbf")),
        ],
        &["handle", "give --mesh"],
    );
}

#[test]
fn before_after_arrows_only_and_the_gizmo_draw_what_they_say() {
    let dir = TempDir::new("looks");
    let head = model("cgal_head.off");
    let smile = root().join("assets/controls/head_smile.json");
    let base = [
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&smile),
        "--view",
        "front",
        "--size",
        "200x100",
    ];
    let shot = |name: &str, extra: &[&str]| {
        let out = dir.path(name);
        let mut args = vec!["render"];
        args.extend(base);
        args.extend(extra);
        args.extend(["--out", arg(&out)]);
        ok(&args);
        image_rgba(&out)
    };
    // Side by side: two 100-pixel panels, the same camera; the right one deformed.
    let (w, h, px) = shot("ba.png", &["--before-after"]);
    assert_eq!((w, h), (200, 100));
    let left: Vec<_> = (0..100)
        .flat_map(|y| (0..100).map(move |x| (x, y)))
        .map(|(x, y)| px[y * 200 + x])
        .collect();
    let right: Vec<_> = (0..100)
        .flat_map(|y| (100..200).map(move |x| (x, y)))
        .map(|(x, y)| px[y * 200 + x])
        .collect();
    let differ = left.iter().zip(&right).filter(|(a, b)| a != b).count();
    assert!(
        differ > 20 && differ < 5000,
        "{differ} pixels differ between rest and smile"
    );
    // Arrows only draw fewer overlay pixels than the full overlay (no spheres).
    let (_, _, plain) = shot("plain.png", &[]);
    let (_, _, full) = shot("full.png", &["--overlay"]);
    let (_, _, arrows) = shot("arrows.png", &["--overlay", "arrows"]);
    let changed = |a: &[[u8; 4]]| a.iter().zip(&plain).filter(|(x, y)| x != y).count();
    assert!(
        changed(&arrows) > 0 && changed(&arrows) < changed(&full),
        "{} vs {}",
        changed(&arrows),
        changed(&full)
    );
    // The gizmo: a red, a green and a blue stroke in the lower left corner.
    let (w, _, g) = shot("gizmo.png", &["--gizmo"]);
    let corner = |pred: &dyn Fn([u8; 4]) -> bool| {
        (50..100)
            .flat_map(|y| (0..60).map(move |x| (x, y)))
            .filter(|&(x, y)| pred(g[y * w as usize + x]))
            .count()
    };
    assert!(
        corner(&|p| p[0] > 150 && p[1] < 120 && p[2] < 120) > 3,
        "no red axis"
    );
    assert!(
        corner(&|p| p[1] > 150 && p[0] < 150 && p[2] < 150) > 3,
        "no green axis"
    );
    assert!(corner(&|p| p[2] > 180 && p[0] < 150) > 3, "no blue axis");
    let out = dir.path("bad.png");
    // A bad flag value is clap's usage error: exit 2, the message names it.
    let r = csrbf(&[
        "render",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&smile),
        "--overlay",
        "circles",
        "--out",
        arg(&out),
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("unknown overlay \"circles\""));
    fails(
        &[
            "render",
            "--mesh",
            arg(&head),
            "--before-after",
            "--out",
            arg(&out),
        ],
        &["--before-after", "--controls"],
    );
    assert!(!out.exists());
}

/// Issue 17, parts 3 and 4: a shove that turns the head inside out says how
/// large a radius would not, and that a sweep cannot; with `"sweep": true`
/// no face folds at any phase, every start lands on its destination, and
/// `fit` + `apply` replay the sweep to the byte.
#[test]
fn a_fold_says_its_remedies_and_a_sweep_folds_nowhere() {
    let dir = TempDir::new("sweep");
    let head = model("cgal_head.off");
    let shove = serde_json::json!({"radius": 2, "controls": [
        {"from": [0.9, 12.9, 4.5], "to": [0.9, 10.5, 4.5]},
        {"from": [-5.89911, 7.551, -1.42866], "to": [-2.9, 9.05, -1.42866]}]});
    let plain = dir.write("plain.json", shove.to_string());
    let out = dir.path("out.ply");
    let deform = |controls: &std::path::Path, phase: &str| -> Value {
        json(&[
            "deform",
            "-q",
            "--mesh",
            arg(&head),
            "--controls",
            arg(controls),
            "--phase",
            phase,
            "--out",
            arg(&out),
            "--force",
            "--json",
        ])
    };
    let v = deform(&plain, "1");
    assert!(v["inside_out_faces"].as_u64().expect("count") > 0, "{v}");
    let remedies = &v["remedies"];
    let scale = remedies["radius_scale"]
        .as_f64()
        .expect("a radius that does not fold");
    assert!(scale > 1.0 && scale <= 4.0, "{remedies}");
    // The bounded search (the default) ran to its end on a mesh this small,
    // and names the sweep without timing it; a full search times it.
    assert_eq!(remedies["complete"], true, "{remedies}");
    assert_eq!(remedies["sweep_untried"], true, "{remedies}");
    let full = deform_json(&head, &plain, &out, &["--force", "--remedies", "full"]);
    assert!(
        full["remedies"]["sweep_steps"].as_u64().expect("steps") > 1,
        "{full}"
    );
    // Issue 39: `--remedies off` searches nothing (clap refuses another word).
    let off = deform_json(&head, &plain, &out, &["--force", "--remedies", "off"]);
    assert!(off["inside_out_faces"].as_u64().expect("count") > 0 && off["remedies"].is_null());
    // The radius it names folds nothing.
    let mut larger = shove.clone();
    larger["radius"] = (2.0 * scale).into();
    let larger = dir.write("larger.json", larger.to_string());
    assert_eq!(deform(&larger, "1")["inside_out_faces"], 0);

    let mut swept = shove.clone();
    swept["sweep"] = true.into();
    let swept = dir.write("swept.json", swept.to_string());
    for phase in ["0.2", "0.5", "0.77", "1"] {
        let v = deform(&swept, phase);
        assert_eq!(v["inside_out_faces"], 0, "phase {phase}: {v}");
        assert_eq!(v["fold_phase"], Value::Null, "phase {phase}");
        assert_eq!(v["remedies"], Value::Null);
    }
    // Every start lands on its destination (1e-6 of the head's diagonal):
    // a mesh whose first vertices are the starts, deformed by the sweep.
    let controls = shove["controls"].as_array().expect("controls");
    let xyz = |c: &Value, k: &str| -> [f64; 3] {
        let a: Vec<f64> = c[k]
            .as_array()
            .expect("xyz")
            .iter()
            .map(|x| x.as_f64().expect("x"))
            .collect();
        [a[0], a[1], a[2]]
    };
    let mut obj = String::new();
    for c in controls {
        let [x, y, z] = xyz(c, "from");
        obj += &format!("v {x} {y} {z}\n");
    }
    obj += "v 30 30 30\nf 1 2 3\n";
    let points = dir.write("starts.obj", obj);
    let landed = dir.path("landed.obj");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&points),
        "--controls",
        arg(&swept),
        "--out",
        arg(&landed),
    ]);
    let landed = csrbf_mesh::read(&landed).expect("landed");
    for (k, c) in controls.iter().enumerate() {
        let [x, y, z] = xyz(c, "to");
        let miss = landed.positions[k]
            .as_dvec3()
            .distance(glam::DVec3::new(x, y, z));
        assert!(
            miss < 1e-6 * 24.134,
            "control {k} misses its destination by {miss}"
        );
    }
    // Its .csrbf keeps the steps: apply gives what deform gave.
    let replay = dir.path("swept.csrbf");
    ok(&[
        "fit",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&swept),
        "--out",
        arg(&replay),
    ]);
    let applied = dir.path("applied.ply");
    ok(&[
        "apply",
        "-q",
        "--mesh",
        arg(&head),
        "--deformation",
        arg(&replay),
        "--out",
        arg(&applied),
    ]);
    assert_eq!(
        std::fs::read(&applied).expect("applied"),
        std::fs::read(&out).expect("deformed")
    );
    let info = json(&[
        "info",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&swept),
        "--json",
    ]);
    assert!(
        info["sweep"]["certified"].as_bool().expect("certified"),
        "{info}"
    );
    assert!(
        info["gradient_bound"].as_f64().expect("bound") > 1.0,
        "{info}"
    );
    // A bad sweep key is named.
    let mut bad = shove.clone();
    bad["sweep"] = serde_json::json!({"steps": 0});
    let bad = dir.write("bad.json", bad.to_string());
    fails(
        &[
            "deform",
            "--mesh",
            arg(&head),
            "--controls",
            arg(&bad),
            "--out",
            arg(&out),
            "--force",
        ],
        &["bad.json", "sweep.steps", "whole number from 1"],
    );
}
