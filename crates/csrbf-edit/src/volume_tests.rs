//! Volume morphs: the cell check against a plain reference, boundary-driven
//! morphs landing where they are told, and refusals.

use csrbf::synthetic::Rng;
use csrbf_mesh::volume::shapes::{self, box_with_cavity};
use csrbf_mesh::volume::{CellKind, VolumeMesh};
use glam::DVec3;
use serde_json::json;

use super::*;

/// The plain reference: inside-out tetrahedra by their signed volume,
/// (d - a) . ((b - a) x (c - a)) / 6.
fn reference_inverted(mesh: &VolumeMesh, points: &[DVec3]) -> Vec<u32> {
    (0..mesh.cells.len())
        .filter(|&c| mesh.cells.kinds[c] == CellKind::Tetra)
        .filter(|&c| {
            let v = mesh.cells.cell(c);
            let [a, b, cc, d] = [0, 1, 2, 3].map(|k| points[v[k] as usize]);
            (d - a).dot((b - a).cross(cc - a)) / 6.0 <= 0.0
        })
        .map(|c| c as u32)
        .collect()
}

fn morph_file(value: serde_json::Value) -> ControlFile {
    ControlFile::parse(&value.to_string()).expect("control file")
}

/// Seeded random morphs of the box, from gentle to folding: the count is
/// the reference's, 0 only when the reference finds none, and the first
/// inversion is where the reference starts to find one.
#[test]
fn inverted_cells_are_the_references_on_random_morphs() {
    let mesh = box_with_cavity(7, 0.3);
    let mut rng = Rng::new(43);
    let mut folded = 0;
    for case in 0..12 {
        let n = 3 + case % 4;
        let scale = 0.05 + 0.12 * case as f64;
        let controls: Vec<_> = (0..n)
            .map(|_| {
                let from = (rng.vec3() - 0.5) * 1.6;
                let to = from + (rng.vec3() - 0.5) * scale * 2.0;
                json!({"from": [from.x, from.y, from.z], "to": [to.x, to.y, to.z]})
            })
            .collect();
        let file = morph_file(json!({"radius": 0.6, "controls": controls}));
        let (moved, report) =
            morph_volume(&mesh, &file, "case", 1.0, false, &mut |_| {}).expect("morph");
        let want = reference_inverted(&mesh, &moved);
        assert!(
            report.cells.inverted == want,
            "case {case}: {} against {}",
            report.cells.inverted.len(),
            want.len()
        );
        assert_eq!(report.cells.cells, mesh.zone_cells(shapes::FLUID).len());
        if want.is_empty() {
            assert_eq!(report.cells.inverted.len(), 0);
        } else {
            folded += 1;
            let p = report.cells.first_inversion.expect("a first inversion");
            assert!(p > 0.0 && p <= 1.0);
            let at = |s: f64| {
                let (m, _) =
                    morph_volume(&mesh, &file, "case", s, false, &mut |_| {}).expect("morph");
                reference_inverted(&mesh, &m).len()
            };
            // Asked for a phase past it, the report gives the same phase of
            // the document (not a share of the phase asked for).
            if p < 0.9 {
                let (_, later) =
                    morph_volume(&mesh, &file, "case", 0.95, false, &mut |_| {}).expect("morph");
                let q = later.cells.first_inversion.expect("turns before 0.95");
                assert!((q - p).abs() < 1e-9, "case {case}: {q} at 0.95 against {p}");
            }
            assert_eq!(at((p - 1e-6).max(0.0)), 0, "case {case}: before {p}");
            assert!(at((p + 1e-6).min(1.0)) > 0, "case {case}: after {p}");
            assert!(!report.advice.is_empty());
        }
    }
    assert!(
        (2..=10).contains(&folded),
        "the cases span both ({folded} fold)"
    );
}

/// Chained maps are scanned: the phase found is where the reference
/// starts to find an inside-out cell.
#[test]
fn chained_maps_find_their_first_inversion_by_scanning() {
    let mesh = box_with_cavity(6, 0.0);
    let pull = |x: f64| {
        json!({"radius": 0.5, "controls": [{"from": [x, 0.0, 0.0], "to": [x + 0.45, 0.0, 0.0]},
                                          {"from": [x + 0.3, 0.0, 0.0], "to": [x + 0.3, 0.0, 0.0]}]})
    };
    let file = morph_file(json!({"combine": "chain", "deformations": [pull(-0.2), pull(0.1)]}));
    let (moved, report) =
        morph_volume(&mesh, &file, "chain", 1.0, false, &mut |_| {}).expect("morph");
    assert_eq!(report.cells.inverted, reference_inverted(&mesh, &moved));
    assert!(!report.cells.inverted.is_empty(), "the pulls fold");
    let p = report.cells.first_inversion.expect("first");
    let at = |s: f64| {
        let (m, _) = morph_volume(&mesh, &file, "chain", s, false, &mut |_| {}).expect("morph");
        reference_inverted(&mesh, &m).len()
    };
    assert_eq!(at(p - 1e-6), 0);
    assert!(at((p + 1e-6).min(1.0)) > 0);
}

/// Nodes out of every control's reach keep their coordinates bit for bit,
/// and zones are regions: a deformation on `inner` moves none of `outer`.
#[test]
fn a_volume_morph_leaves_unreached_nodes_exactly_and_knows_zones() {
    let mesh = box_with_cavity(6, 0.34);
    let file = morph_file(json!({"radius": 0.5, "region": {"group": "inner"},
        "controls": [{"from": [0.34, 0.0, 0.0], "to": [0.4, 0.0, 0.0]}]}));
    let (moved, report) =
        morph_volume(&mesh, &file, "inner", 1.0, false, &mut |_| {}).expect("morph");
    assert!(report.moved > 0);
    let inner = mesh.zone_nodes(shapes::INNER);
    for (v, (a, b)) in mesh.points.iter().zip(&moved).enumerate() {
        if inner.binary_search(&(v as u32)).is_err() {
            assert_eq!(a, b, "node {v} is not in the region");
        }
    }
}

fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

fn temp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("csrbf-volume-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("dir");
    d
}

/// The checks of issue 43: held zones bit-exact, moved zones on their
/// displacements to 1e-6 of the diagonal, with every boundary node and with
/// a subset within a tolerance; a per-node file and a control document.
#[test]
fn boundary_morphs_hold_and_move_zones_where_told() {
    let mesh = box_with_cavity(8, 0.26);
    let diag = 2.0 * 3f64.sqrt();
    let dir = temp("boundary");
    let inner = mesh.zone_nodes(shapes::INNER);
    let outer = mesh.zone_nodes(shapes::OUTER);
    let table: String = inner
        .iter()
        .map(|&v| {
            let p = mesh.points[v as usize];
            format!("{v}, {} {} {}\n", 0.1 * p.y, -0.05 * p.x, 0.02)
        })
        .collect();
    write(&dir, "inner.txt", &format!("# node dx dy dz\n{table}"));
    write(
        &dir,
        "lift.json",
        &json!({"radius": 0.8, "controls": [{"from": [0.0, 0.25, 0.0], "to": [0.0, 0.35, 0.0]}]})
            .to_string(),
    );
    let motions = [
        json!({"zone": "inner", "translate": [0.05, 0.02, 0.0]}),
        json!({"zone": "inner", "rotate": {"axis": [0, 0, 1], "angle_deg": 10}, "scale": 1.1}),
        json!({"zone": "inner", "displacements": "inner.txt"}),
        json!({"zone": "inner", "controls": "lift.json"}),
    ];
    for (k, motion) in motions.iter().enumerate() {
        for tolerance in [None, Some(1e-4)] {
            let doc = json!({"boundary": {"radius": 0.9, "tolerance": tolerance,
                "move": [motion], "hold": ["outer"]}});
            let morph = BoundaryMorph::from_value(&doc, &dir.join("morph.json")).expect("parse");
            let (moved, report) = morph_boundary(&mesh, &morph, 1.0, &mut |_| {}).expect("morph");
            let b = report.boundary.as_ref().expect("figures");
            assert_eq!(b.moved_nodes, inner.len());
            assert_eq!(b.held_nodes, outer.len());
            for &v in &outer {
                assert_eq!(moved[v as usize], mesh.points[v as usize], "held node {v}");
            }
            let (nodes, disp, ..) = prescribe(&mesh, &morph, &mut |_| {}).expect("prescribed");
            for (v, d) in nodes.iter().zip(&disp) {
                let want = mesh.points[*v as usize] + *d;
                assert!(
                    moved[*v as usize].distance(want) <= 1e-6 * diag,
                    "motion {k}: node {v}"
                );
            }
            assert!(
                report.moved > inner.len(),
                "the interior follows (motion {k})"
            );
            match tolerance {
                None => {
                    assert_eq!(report.controls, inner.len() + outer.len());
                    assert!(
                        b.max_error < 1e-6 * diag,
                        "every node interpolated: {}",
                        b.max_error
                    );
                }
                Some(t) => {
                    assert!(b.max_error <= t, "motion {k}: {} > {t}", b.max_error);
                    // The report says which nodes: prescribed ones, ascending.
                    assert_eq!(b.control_nodes.len(), report.controls);
                    assert!(b.control_nodes.windows(2).all(|w| w[0] < w[1]));
                    assert!(b.control_nodes.iter().all(|v| {
                        inner.binary_search(v).is_ok() || outer.binary_search(v).is_ok()
                    }));
                    assert!(report.controls <= inner.len() + outer.len());
                }
            }
            assert!(
                report.cells.inverted.is_empty(),
                "motion {k}: {}",
                report.cells.summary()
            );
        }
    }
    // A rigid translation within a held box: the gap shrinks, cells get
    // worse, and the report says by how much.
    let doc = json!({"boundary": {"radius": 1.2, "move": [{"zone": "inner", "translate": [0.3, 0, 0]}], "hold": ["outer"]}});
    let morph = BoundaryMorph::from_value(&doc, &dir.join("m.json")).expect("parse");
    let (_, report) = morph_boundary(&mesh, &morph, 1.0, &mut |_| {}).expect("morph");
    assert!(report.cells.min_scaled_jacobian_after < report.cells.min_scaled_jacobian_before);
    let j = report.to_json();
    assert_eq!(j["cells"]["cells"], json!(report.cells.cells));
    assert_eq!(j["cells"]["zones"][0]["name"], json!("fluid"));
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad morph documents and files are refused, naming the file and the
/// path or line.
#[test]
fn bad_boundary_morphs_are_refused_by_name() {
    let mesh = box_with_cavity(4, 0.3);
    let dir = temp("bad");
    let src = dir.join("morph.json");
    let parse = |v: serde_json::Value| {
        BoundaryMorph::from_value(&v, &src)
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    let cases = [
        (
            json!({"boundary": {"move": [{"zone": "inner", "translate": [0, 0, 1]}]}}),
            "boundary.radius: missing",
        ),
        (
            json!({"boundary": {"radius": -1, "move": [{"zone": "inner", "translate": [0, 0, 1]}]}}),
            "boundary.radius: must be",
        ),
        (
            json!({"boundary": {"radius": 1, "move": []}}),
            "boundary.move: missing",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner"}]}}),
            "boundary.move[0]: says no motion",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "translate": [0, 0, 1], "displacements": "a.txt"}]}}),
            "more than one kind",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "transalte": [0, 0, 1]}]}}),
            "did you mean \"translate\"",
        ),
        (
            json!({"boundary": {"radius": 1, "tolerance": 0, "move": [{"zone": "inner", "translate": [0, 0, 1]}]}}),
            "boundary.tolerance: must be > 0",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "scale": -2}]}}),
            "boundary.move[0].scale",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "rotate": {"axis": [0, 0, 0], "angle_deg": 3}}]}}),
            "the axis must not be zero",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "rotate": {"axis": [0, 0, 1], "angel_deg": 3}}]}}),
            "boundary.move[0].rotate",
        ),
        (
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "rotate": {"axis": [0, 0, 1]}}]}}),
            "the angle in degrees",
        ),
        (
            json!({"boundary": {"radius": 1, "kernel": "c9", "move": [{"zone": "inner", "translate": [0, 0, 1]}]}}),
            "boundary.kernel",
        ),
    ];
    for (doc, says) in cases {
        let e = parse(doc.clone()).expect_err(&doc.to_string());
        assert!(e.contains(says), "{doc}: {e}");
    }
    let run = |doc: serde_json::Value| -> String {
        let m = BoundaryMorph::from_value(&doc, &src).expect("parses");
        morph_boundary(&mesh, &m, 1.0, &mut |_| {})
            .map(|_| ())
            .expect_err("refused")
            .to_string()
    };
    let e =
        run(json!({"boundary": {"radius": 1, "move": [{"zone": "wing", "translate": [0, 0, 1]}]}}));
    assert!(
        e.contains("boundary.move[0]")
            && e.contains("no zone \"wing\"")
            && e.contains("inner (2D)"),
        "{e}"
    );
    let e = run(
        json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "translate": [0, 0, 0.1]}], "hold": ["far"]}}),
    );
    assert!(e.contains("boundary.hold[0]"), "{e}");
    let inner = mesh.zone_nodes(shapes::INNER);
    for (text, says) in [
        ("0 1 2\n", "inner.txt:1: expected `node dx dy dz`"),
        ("# header\n999999 0 0 0\n", "inner.txt:2: node 999999"),
        ("x 0 0 0\n", "not a node index"),
        ("0 0 nan 0\n", "not a finite number"),
        ("0 0 0 0\n0 1 1 1\n", "node 0 is given twice"),
        (
            &format!("{} 0 0 0\n", inner[0]),
            "gives no displacement for node",
        ),
    ] {
        write(&dir, "inner.txt", text);
        let e = run(
            json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "displacements": "inner.txt"}]}}),
        );
        assert!(e.contains(says), "{text:?}: {e}");
    }
    let e = run(
        json!({"boundary": {"radius": 1, "move": [{"zone": "inner", "displacements": "absent.txt"}]}}),
    );
    assert!(e.contains("absent.txt"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 43's check: a certified morph of a tetrahedral box with a moved
/// inner boundary has no inverted cell at phases 1/4, 1/2, 3/4 and 1 by
/// the reference, where the single map with the same radius inverts some.
#[test]
fn a_certified_sweep_keeps_every_cell_positive_at_every_phase() {
    let mesh = box_with_cavity(8, 0.26);
    let doc = |sweep: bool| {
        json!({"boundary": {"radius": 0.5, "sweep": sweep,
            "move": [{"zone": "inner", "translate": [0.3, 0.1, 0.0]}], "hold": ["outer"]}})
    };
    let src = Path::new("certified.json");
    let plain = BoundaryMorph::from_value(&doc(false), src).expect("parse");
    let (moved, report) = morph_boundary(&mesh, &plain, 1.0, &mut |_| {}).expect("plain");
    let plain_inverted = reference_inverted(&mesh, &moved).len();
    assert_eq!(report.cells.inverted.len(), plain_inverted);
    // The remedies were measured: a radius that inverts none, checked
    // again here by the reference, and the certified sweep's steps.
    let r = report.remedies.as_ref().expect("remedies searched");
    assert!(report.advice.contains("measured"), "{}", report.advice);
    if let Some(f) = r.radius_scale {
        let mut wider = doc(false);
        wider["boundary"]["radius"] = json!(0.5 * f);
        let m = BoundaryMorph::from_value(&wider, src).expect("parse");
        let (moved, _) = morph_boundary(&mesh, &m, 1.0, &mut |_| {}).expect("wider");
        assert!(reference_inverted(&mesh, &moved).is_empty(), "R x {f}");
    }
    assert!(r.radius_scale.is_some() || r.sweep_steps.is_some(), "{r:?}");
    let swept = BoundaryMorph::from_value(&doc(true), src).expect("parse");
    let mut said = Vec::new();
    for phase in [0.25, 0.5, 0.75, 1.0] {
        let (moved, report) = morph_boundary(&mesh, &swept, phase, &mut |n| {
            let (Note::Progress(t) | Note::Warning(t)) = n;
            said.push(t);
        })
        .expect("swept");
        let b = report.boundary.as_ref().expect("figures");
        assert!(b.certified, "{said:?}");
        let steps = b.sweep_steps.expect("steps");
        assert!(steps > 1, "the single map is not certified here ({steps})");
        assert!(
            reference_inverted(&mesh, &moved).is_empty(),
            "phase {phase}: {}",
            report.cells.summary()
        );
        assert!(report.cells.inverted.is_empty());
        // The prescribed nodes are where they were told to be at that phase.
        let inner = mesh.zone_nodes(shapes::INNER);
        for &v in &inner {
            let want = mesh.points[v as usize] + DVec3::new(0.3, 0.1, 0.0) * phase;
            assert!(moved[v as usize].distance(want) < 1e-12);
        }
    }
    // With a tolerance, the sweep still takes every boundary node (a
    // subset's others would be set in place outside its certificate).
    let mut with_tolerance = doc(true);
    with_tolerance["boundary"]["tolerance"] = json!(1e-3);
    let m = BoundaryMorph::from_value(&with_tolerance, src).expect("parse");
    let (moved, report) = morph_boundary(&mesh, &m, 1.0, &mut |_| {}).expect("swept");
    let all = mesh.zone_nodes(shapes::INNER).len() + mesh.zone_nodes(shapes::OUTER).len();
    assert!(report.boundary.as_ref().is_some_and(|b| b.certified));
    assert_eq!(report.controls, all);
    assert!(reference_inverted(&mesh, &moved).is_empty());
    assert!(
        plain_inverted > 0,
        "the single map inverts cells (so the sweep earns its steps): {plain_inverted}"
    );
}
