//! Issue 7: inputs that asked for unbounded work are refused at once, with
//! the limit named, before any file is written.

use crate::support::*;

#[test]
fn endless_movies_and_runs_are_refused_before_any_work() {
    let dir = TempDir::new("limits");
    ok(&[
        "demo",
        "-q",
        "ball",
        "--out",
        arg(&dir.path("d")),
        "--gif",
        "--size",
        "64x48",
    ]);
    let scene = dir.path("d/ball/ball.scene.json");
    assert!(scene.is_file(), "the demo writes its scene");
    let out = dir.path("m.gif");
    let t = std::time::Instant::now();
    fails(
        &["animate", arg(&scene), "--out", arg(&out), "--to", "1e9"],
        &["more than the limit of 100000"],
    );
    assert!(t.elapsed().as_secs() < 20, "refused before rendering");
    assert!(!out.exists());
    // A scene file whose duration is endless: refused by every command.
    let text = std::fs::read_to_string(&scene).expect("scene");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    let mut v = v;
    v["duration"] = serde_json::json!(1e9);
    let endless = dir.write("d/ball/endless.scene.json", v.to_string());
    fails(
        &["export", arg(&endless), "--out", arg(&dir.path("e.glb"))],
        &["duration", "more than the limit"],
    );
    assert!(!dir.path("e.glb").exists());
    // Benchmark runs are bounded (a usage error names the flag).
    let r = csrbf(&["bench", "--scene", "fish", "--runs", "4294967295"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--runs"));
}

/// Issue 7: a legal long output name is not refused for its temporary's sake.
#[test]
fn a_255_byte_output_name_is_written() {
    let dir = TempDir::new("longname");
    let head = model("cgal_head.off");
    let c = root().join("assets/controls/head_smile.json");
    let name = format!("{}.ply", "h".repeat(251));
    assert_eq!(name.len(), 255);
    let out = dir.path(&name);
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&c),
        "--out",
        arg(&out),
    ]);
    assert!(out.is_file());
    assert_eq!(dir.files(), vec![name], "no temporary left beside it");
}

/// Issue 7: SIGTERM in the middle of a movie leaves no partial file and no
/// ffmpeg; a temporary that a killed run left is removed by the next run.
#[cfg(unix)]
#[test]
fn an_interrupted_movie_leaves_nothing_and_stale_temporaries_are_swept() {
    let dir = TempDir::new("interrupt");
    ok(&[
        "demo",
        "-q",
        "ball",
        "--out",
        arg(&dir.path("d")),
        "--gif",
        "--size",
        "64x48",
    ]);
    let scene = dir.path("d/ball/ball.scene.json");
    for out in ["m.gif", "frames/", "m.mp4"] {
        let target = dir.path(out);
        let mut child = command()
            .args([
                "animate",
                arg(&scene),
                "--out",
                arg(&target),
                "--size",
                "320x240",
                "--fps",
                "60",
            ])
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        // Wait until it is writing, then stop it.
        let started = std::time::Instant::now();
        while !std::fs::read_dir(dir.path(""))
            .expect("dir")
            .flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with(".csrbf-"))
        {
            assert!(
                started.elapsed().as_secs() < 60,
                "{out}: never started writing"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let _ = std::process::Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status();
        let status = child.wait().expect("wait");
        assert_eq!(status.code(), Some(130), "{out}: exit code");
        let left: Vec<String> = std::fs::read_dir(dir.path(""))
            .expect("dir")
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".csrbf-") || n.starts_with("m.") || n.starts_with("frames"))
            .collect();
        assert!(left.is_empty(), "{out}: left {left:?}");
    }
    // A temporary of a process that is gone is removed by the next run there.
    let stale = dir.write(".csrbf-999999999-0.tmp", "partial");
    let head = model("cgal_head.off");
    let c = root().join("assets/controls/head_smile.json");
    ok(&[
        "deform",
        "-q",
        "--mesh",
        arg(&head),
        "--controls",
        arg(&c),
        "--out",
        arg(&dir.path("h.ply")),
    ]);
    assert!(!stale.exists(), "a stale temporary survived");
}

/// Issue 7: 20,000 controls all within R of each other are refused at once
/// with the estimate, the limit and a radius that fits (it used to run for
/// minutes at 6.4 GB).
#[test]
fn a_dense_control_file_is_refused_with_a_radius_that_fits() {
    let dir = TempDir::new("dense");
    let mut s = 1u64;
    let mut r = || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let controls: Vec<String> = (0..20_000)
        .map(|_| {
            let (x, y, z) = (r(), r(), r());
            format!(r#"{{"from": [{x}, {y}, {z}], "to": [{x}, {y}, {z}]}}"#)
        })
        .collect();
    let c = dir.write(
        "dense.json",
        format!(r#"{{"radius": 10, "controls": [{}]}}"#, controls.join(",")),
    );
    let head = model("cgal_head.off");
    let out = dir.path("o.ply");
    let t = std::time::Instant::now();
    fails(
        &[
            "deform",
            "--mesh",
            arg(&head),
            "--controls",
            arg(&c),
            "--out",
            arg(&out),
        ],
        &[
            "dense.json",
            "the limit of 4 GiB",
            "smaller R",
            "--allow-large",
        ],
    );
    assert!(t.elapsed().as_secs() < 30, "refused from the estimate");
    assert!(!out.exists());
}
