//! Volume meshes (issue 43) through the binary: `info`, `deform` by a
//! control file and by a boundary-driven morph, between formats, the cell
//! check in `--json`, `render` of the boundary with inverted cells, and
//! refusals that write nothing.

use crate::support::*;

fn sample() -> std::path::PathBuf {
    root().join("assets/volume/sphere_in_box.msh")
}

#[test]
fn info_of_a_gmsh_file_names_its_cells_zones_and_shape() {
    let out = ok(&["info", "--mesh", arg(&sample()), "--json"]);
    let v: serde_json::Value = serde_json::from_str(&out).expect("json");
    assert_eq!(v["cell_kinds"]["tetra"], 2898, "{v}");
    let zones: Vec<&str> = v["zones"]
        .as_array()
        .expect("zones")
        .iter()
        .map(|z| z["name"].as_str().expect("name"))
        .collect();
    assert_eq!(zones, ["outer", "inner", "fluid"]);
    assert_eq!(v["inverted_or_flat"], 0);
    let sj = v["min_scaled_jacobian"].as_f64().expect("sj");
    assert!(sj > 0.05 && sj <= 1.0, "{sj}");
    assert_eq!(v["solid_cells"], 2898);
}

#[test]
fn a_boundary_morph_moves_the_sphere_holds_the_box_and_keeps_every_cell() {
    let dir = TempDir::new("volume-morph");
    let morph = dir.write(
        "morph.json",
        r#"{"boundary": {"radius": 1.2, "move": [{"zone": "inner", "translate": [0.15, 0.05, 0]}], "hold": ["outer"]}}"#,
    );
    let rest = csrbf_mesh::volume::read(&sample()).expect("read");
    for ext in ["vtu", "vtk", "msh"] {
        let out = dir.path(&format!("moved.{ext}"));
        let v = deform_json(&sample(), &morph, &out, &[]);
        assert_eq!(v["cells"]["inverted_cells"], 0, "{v}");
        assert!(
            v["cells"]["min_scaled_jacobian_after"]
                .as_f64()
                .expect("sj")
                > 0.0
        );
        assert_eq!(v["boundary"]["moved_nodes"], rest.zone_nodes(2).len());
        let back = csrbf_mesh::volume::read(&out).expect("read back");
        assert_eq!(back.cells, rest.cells, "{ext}: cells kept");
        assert_eq!(back.zones, rest.zones, "{ext}: zones kept");
        for v in rest.zone_nodes(1) {
            assert_eq!(
                back.points[v as usize], rest.points[v as usize],
                "{ext}: held node {v}"
            );
        }
        for v in rest.zone_nodes(2) {
            let want = rest.points[v as usize] + glam::DVec3::new(0.15, 0.05, 0.0);
            assert!(
                back.points[v as usize].distance(want) < 1e-9,
                "{ext}: moved node {v}"
            );
        }
    }
}

#[test]
fn a_morph_that_inverts_cells_says_which_from_when_and_what_to_do() {
    let dir = TempDir::new("volume-fold");
    // The sphere pushed 0.5 towards a held wall 0.6 away, with a small radius.
    let morph = dir.write(
        "push.json",
        r#"{"boundary": {"radius": 0.45, "move": [{"zone": "inner", "translate": [0.5, 0, 0]}], "hold": ["outer"]}}"#,
    );
    let out = dir.path("pushed.vtu");
    let sample = sample();
    let mut args = deform_args(&sample, &morph, &out);
    args.push("--json");
    let done = csrbf(&args);
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&done.stdout).expect("json");
    let n = v["cells"]["inverted_cells"].as_u64().expect("count");
    assert!(n > 0, "{v}");
    let p = v["cells"]["first_inversion"].as_f64().expect("phase");
    assert!(p > 0.0 && p < 1.0, "{p}");
    let stderr = String::from_utf8_lossy(&done.stderr);
    assert!(
        stderr.contains("warning:") && stderr.contains("turn inside out"),
        "{stderr}"
    );
    // Stopped before the first inversion, none is inverted.
    let early = deform_json(
        &sample,
        &morph,
        &out,
        &["--phase", &format!("{}", p * 0.98)],
    );
    assert_eq!(early["cells"]["inverted_cells"], 0, "{early}");
}

#[test]
fn a_control_file_moves_every_node_and_regions_name_zones() {
    let dir = TempDir::new("volume-controls");
    let c = dir.write(
        "pull.json",
        r#"{"radius": 0.6, "region": {"group": "fluid"}, "controls": [{"from": [0.4, 0, 0], "to": [0.5, 0, 0]}]}"#,
    );
    let out = dir.path("pulled.vtu");
    let v = deform_json(&sample(), &c, &out, &[]);
    assert!(v["moved"].as_u64().expect("moved") > 10, "{v}");
    assert_eq!(v["controls"], 1);
    assert_eq!(v["cells"]["inverted_cells"], 0);
}

#[test]
fn bad_volume_inputs_are_refused_and_nothing_is_written() {
    let dir = TempDir::new("volume-bad");
    let good = dir.write(
        "morph.json",
        r#"{"boundary": {"radius": 1, "move": [{"zone": "inner", "translate": [0.1, 0, 0]}]}}"#,
    );
    let wing = dir.write(
        "wing.json",
        r#"{"boundary": {"radius": 1, "move": [{"zone": "wing", "translate": [0.1, 0, 0]}]}}"#,
    );
    let out = dir.path("out.vtu");
    fails(
        &deform_args(&sample(), &wing, &out),
        &[
            "wing.json",
            "boundary.move[0]",
            "no zone \"wing\"",
            "outer (2D)",
        ],
    );
    let ply = dir.path("out.ply");
    fails(
        &deform_args(&sample(), &good, &ply),
        &["out.ply", "volume mesh", ".vtu"],
    );
    let text = std::fs::read_to_string(sample()).expect("sample");
    let cut = dir.write("cut.msh", &text[..text.len() / 2]);
    fails(&deform_args(&cut, &good, &out), &["cut.msh"]);
    let bad_index = dir.write(
        "bad.vtk",
        "# vtk DataFile Version 4.2\nbad\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 double\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 9\nCELL_TYPES 1\n10\n",
    );
    fails(
        &["info", "--mesh", arg(&bad_index)],
        &["bad.vtk", "cell 0", "9", "4 nodes"],
    );
    // A surface written with a volume format's extension: told why.
    let smile = root().join("assets/controls/head_smile.json");
    let vtu = dir.path("out_head.vtu");
    fails(
        &deform_args(&model("cgal_head.off"), &smile, &vtu),
        &["out_head.vtu", "holds a volume mesh", ".obj"],
    );
    let files = dir.files();
    assert!(
        !files.iter().any(|f| f.starts_with("out")),
        "nothing written: {files:?}"
    );
}

#[test]
fn render_draws_the_boundary_and_the_inverted_cells_in_red() {
    let dir = TempDir::new("volume-render");
    let morph = dir.write(
        "push.json",
        r#"{"boundary": {"radius": 0.45, "move": [{"zone": "inner", "translate": [0.5, 0, 0]}], "hold": ["outer"]}}"#,
    );
    let sample = sample();
    let run = |folds: bool, name: &str| {
        let png = dir.path(name);
        let mut args = vec![
            "render",
            "-q",
            "--mesh",
            arg(&sample),
            "--controls",
            arg(&morph),
            "--size",
            "200x150",
            "--out",
            arg(&png),
        ];
        if folds {
            args.push("--folds");
        }
        ok(&args);
        let (_, _, px) = crate::pictures::image_rgba(&png);
        px.iter()
            .filter(|p| {
                let (r, g, b) = (u16::from(p[0]), u16::from(p[1]), u16::from(p[2]));
                // Red seen through the see-through boundary: reddish.
                r > g + 50 && r > b + 50
            })
            .count()
    };
    assert!(
        run(true, "folds.png") > 10,
        "the inverted cells are drawn red"
    );
    assert_eq!(run(false, "plain.png"), 0, "red only with --folds");
}
