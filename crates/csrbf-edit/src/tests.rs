//! The edit layer's own tests: the control reader under mutation, the one
//! road (fit, deform, report) against the engine's plain calls, and the
//! remedies' budget.

use csrbf::synthetic::{Rng, grid};
use csrbf::{Combine, FittedStage, compose_with_groups};
use csrbf_mesh::{Faces, Mesh};
use glam::DVec3;

use crate::{Checks, ControlFile, Edit, Remedies, RemedySearch, fit, remedies};

/// A flat grid of `n` x `n` cells as a mesh.
/// The remedies of `edit` on `mesh` at phase 1, chained, with the search `s`.
fn search_remedies(mesh: &Mesh, edit: &Edit, s: RemedySearch) -> Remedies {
    let tris = mesh.faces.triangles();
    remedies(
        &mesh.positions,
        &tris,
        &edit.specs,
        Combine::Chain,
        1.0,
        &|_| None,
        s,
        1.0,
    )
    .expect("remedies")
}

fn grid_mesh(n: usize) -> Mesh {
    let (positions, tris) = grid(n);
    let mut faces = Faces::new();
    for t in &tris {
        faces.push(t);
    }
    Mesh {
        positions,
        faces,
        ..Mesh::default()
    }
}

/// A pull at the grid's middle that folds it at R 0.25 (C2).
const FOLDING: &str = r#"{"radius": 0.25, "kernel": "c2",
    "controls": [{"from": [0.5, 0.5, 0], "to": [0.8, 0.5, 0]}]}"#;

#[test]
fn a_destination_beyond_the_range_of_numbers_is_named() {
    let text = r#"{"radius": 1, "controls": [{"from": [0, 0, 0], "to": [1e300, 0, 0]}]}"#;
    let e = ControlFile::parse(text).expect_err("1e300");
    assert!(
        e.to_string().contains("controls[0].to[0]") && e.to_string().contains("beyond the range"),
        "{e}"
    );
}

/// Issue 7: seeded mutations of control files give an error or a valid
/// value, never a panic.
#[test]
fn the_control_reader_survives_thousands_of_mutations() {
    use csrbf::fuzz::mutate;
    let controls = [
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/controls/head_smile.json")).expect("smile"),
        br#"{"combine": "add", "deformations": [
            {"radius": 1, "kernel": "c4", "phase": 0.5, "region": {"box": {"min": [0,0,0], "max": [1,1,1]}, "falloff": 0.2},
             "controls": [{"from": [0,0,0], "to": [0,0,1]}]},
            {"radius": 2, "handle": {"select": {"group": "ear"}, "rotate": {"axis": [0,0,1], "angle_deg": 30, "pivot": [1,2,3]}, "scale": 1.1},
             "anchor": {"vertices": [1, 2, 3]}}]}"#
            .to_vec(),
    ];
    let all: Vec<&[u8]> = vec![&controls[0], &controls[1]];
    let mut rng = Rng::new(4242);
    let (mut read, mut refused) = (0, 0);
    for case in 0..4000 {
        let input = mutate(all[case % all.len()], &mut rng, &all);
        let result = std::panic::catch_unwind(|| {
            ControlFile::parse(&String::from_utf8_lossy(&input)).is_ok()
        });
        match result {
            Ok(true) => read += 1,
            Ok(false) => refused += 1,
            Err(_) => panic!("case {case} panicked"),
        }
    }
    assert!(read > 0 && refused > 0, "{read} read, {refused} refused");
}

/// The road gives the positions of the engine's own calls bit for bit, and
/// its report's serialised form says what the diagnostics say, the fold
/// phase scaled to the phase asked for.
#[test]
fn the_road_deforms_as_the_engine_does_and_reports_it_once() {
    let mesh = grid_mesh(30);
    let file = ControlFile::parse(FOLDING).expect("parse");
    let mut notes = Vec::new();
    let edit = fit(&file, "pull.json", Some(&mesh), false, &mut |n| {
        notes.push(n)
    })
    .expect("fit");
    assert!(
        notes
            .iter()
            .any(|n| matches!(n, crate::Note::Progress(t) if t.starts_with("fitted 1 controls"))),
        "{notes:?}"
    );
    let (moved, report) = edit
        .deform(&mesh, 0.9, &Checks::default(), RemedySearch::Full)
        .expect("deform");
    let d = csrbf::Deformation::fit(
        &[DVec3::new(0.5, 0.5, 0.0)],
        &[DVec3::new(0.8, 0.5, 0.0)],
        csrbf::FitOptions::new(0.25).with_kernel(csrbf::Kernel::C2),
    )
    .expect("fit");
    let plain = compose_with_groups(
        &mesh.positions,
        &[FittedStage::new(d).with_phase(0.9)],
        Combine::Chain,
        &|_| None,
    )
    .expect("compose");
    assert_eq!(moved, plain);
    let v = report.to_json();
    assert_eq!(v["vertices"], mesh.positions.len());
    assert_eq!(v["inside_out_faces"], report.diagnostics.inside_out.len());
    assert!(
        !report.diagnostics.inside_out.is_empty(),
        "the pull must fold"
    );
    let fold = v["fold_phase"].as_f64().expect("folds");
    assert!(fold > 0.0 && fold <= 0.9, "{fold}");
    assert_eq!(
        v["warning_kinds"].as_array().map(Vec::len),
        Some(report.diagnostics.warnings.len())
    );
    // Folded, so the remedies were searched to the end and are in the form.
    let r = &v["remedies"];
    assert_eq!(r["complete"], true, "{r}");
    assert!(r["radius_scale"].as_f64().expect("scale") > 1.0, "{r}");
    assert!(r["sweep_steps"].as_u64().expect("steps") > 1, "{r}");
    let advice = r["advice"].as_str().expect("advice");
    assert!(
        advice.starts_with("to keep it from folding: a radius"),
        "{advice}"
    );
    assert_eq!(advice, report.advice());
}

/// A search with no time finds nothing and says it stopped; a bounded one
/// gets at least the floor, and a full one has no bound.
#[test]
fn the_remedies_search_keeps_to_its_budget() {
    let mesh = grid_mesh(30);
    let file = ControlFile::parse(FOLDING).expect("parse");
    let edit = fit(&file, "pull.json", Some(&mesh), false, &mut |_| {}).expect("fit");
    let search = |s| search_remedies(&mesh, &edit, s);
    let r = search(RemedySearch::Off);
    assert!(!r.found() && !r.complete && r.sweep_untried, "{r:?}");
    assert!(
        r.advice()
            .contains("\"sweep\": true, which cannot fold (not timed"),
        "{}",
        r.advice()
    );
    // A bounded search leaves the sweep untimed but finds the radius here.
    let r = search(RemedySearch::Bounded);
    assert!(
        r.radius_scale.is_some() && r.sweep.is_none() && r.sweep_untried,
        "{r:?}"
    );
    let floor = RemedySearch::FLOOR_MS / 1e3;
    assert_eq!(
        RemedySearch::Bounded.budget(1.0).map(|b| b.as_secs_f64()),
        Some(floor)
    );
    assert_eq!(
        RemedySearch::Bounded
            .budget(5000.0)
            .map(|b| b.as_secs_f64()),
        Some(5.0)
    );
    assert_eq!(RemedySearch::Full.budget(1.0), None);
    // Off in a deform: no search at all.
    let (_, report) = edit
        .deform(&mesh, 1.0, &Checks::default(), RemedySearch::Off)
        .expect("deform");
    assert!(report.remedies.is_none() && report.to_json()["remedies"].is_null());
}

/// A deformation that needs the mesh is refused without one, naming the
/// document and the deformation; a part the mesh lacks is named with the
/// parts it has.
#[test]
fn what_the_mesh_must_give_is_named() {
    let handle = ControlFile::parse(
        r#"{"deformations": [{"radius": 1, "controls": []},
            {"radius": 1, "handle": {"select": {"sphere": {"center": [0, 0, 0], "radius": 0.2}},
             "translate": [0, 0, 0.1]}}]}"#,
    )
    .expect("parse");
    let e = fit(&handle, "h.json", None, false, &mut |_| {}).expect_err("no mesh");
    assert_eq!(
        e.to_string(),
        "h.json: deformations[1]: handle: a handle is sampled on the mesh; give the mesh"
    );
    let part = ControlFile::parse(
        r#"{"radius": 1, "region": {"group": "nose"}, "controls": [{"from": [0, 0, 0], "to": [0, 0, 1]}]}"#,
    )
    .expect("parse");
    let e = fit(&part, "p.json", Some(&grid_mesh(4)), false, &mut |_| {}).expect_err("no nose");
    assert!(
        e.to_string()
            .starts_with("p.json: region: names part \"nose\""),
        "{e}"
    );
}

/// From a new user's trial: with a region, a sweep does not keep the
/// region's cut edge from folding, so it is never named untried, and a full
/// search names it only when its trial folds nothing.
#[test]
fn a_sweep_is_advised_for_a_region_only_when_its_trial_folds_nothing() {
    let mesh = grid_mesh(30);
    let text = r#"{"radius": 0.25, "kernel": "c2",
        "region": {"sphere": {"center": [0.5, 0.5, 0], "radius": 0.2}},
        "controls": [{"from": [0.5, 0.5, 0], "to": [0.8, 0.5, 0]}]}"#;
    let file = ControlFile::parse(text).expect("parse");
    let edit = fit(&file, "cut.json", Some(&mesh), false, &mut |_| {}).expect("fit");
    let search = |s| search_remedies(&mesh, &edit, s);
    assert!(!search(RemedySearch::Bounded).sweep_untried);
    if search(RemedySearch::Full).sweep.is_some() {
        let mut swept = file.clone();
        swept.deformations[0].sweep = Some(csrbf::SweepOptions::default());
        let edit = fit(&swept, "cut.json", Some(&mesh), false, &mut |_| {}).expect("fit");
        let (_, report) = edit
            .deform(&mesh, 1.0, &Checks::default(), RemedySearch::Off)
            .expect("deform");
        assert!(report.diagnostics.inside_out.is_empty());
    }
}

/// An arm: a box 4 long (X), 0.5 thick, finely divided.
fn arm() -> Mesh {
    csrbf_mesh::shapes::subdivided_box(glam::Vec3::new(4.0, 0.5, 0.5), [80, 8, 8])
}

/// The arm's right end (x > 1) turned 75 degrees about Z at x = 1, its left
/// end (x < -1) the anchor; a sweep when asked.
fn turned_arm(sweep: bool) -> String {
    format!(
        r#"{{"radius": 1.0, "sweep": {sweep},
            "handle": {{"select": {{"box": {{"min": [1, -1, -1], "max": [3, 1, 1]}}}},
                       "rotate": {{"axis": [0, 0, 1], "angle_deg": 75, "pivot": [1, 0, 0]}}}},
            "anchor": {{"box": {{"min": [-3, -1, -1], "max": [-1, 1, 1]}}}}}}"#
    )
}

/// Issue 42: a handle's vertices turn as a bone turns them (their mutual
/// distances kept exactly at full phase, and at every phase in a sweep),
/// no face among them turns inside out at any phase, the anchor's vertices
/// stay exactly, and the report names no fold there; the live session and
/// the saved file give the same positions.
#[test]
fn a_handle_turns_its_vertices_rigidly_and_holds_its_anchor() {
    let mesh = arm();
    let p: Vec<DVec3> = mesh.positions.iter().map(|v| v.as_dvec3()).collect();
    let chosen: Vec<usize> = (0..p.len()).filter(|&i| p[i].x >= 1.0).collect();
    let held: Vec<usize> = (0..p.len()).filter(|&i| p[i].x <= -1.0).collect();
    let tris = mesh.faces.triangles();
    let inside: Vec<[u32; 3]> = (tris.iter())
        .filter(|t| t.iter().all(|&v| p[v as usize].x >= 1.0))
        .copied()
        .collect();
    let diagonal = mesh.diagonal() as f64;
    for sweep in [false, true] {
        let file = ControlFile::parse(&turned_arm(sweep)).expect("parse");
        for phase in [0.5, 1.0] {
            let mut moved = mesh.clone();
            let report = crate::apply::deform_mesh(&mut moved, &file, phase).expect("deform");
            let q: Vec<DVec3> = moved.positions.iter().map(|v| v.as_dvec3()).collect();
            // Distances among the handle's vertices: exact at full phase; a
            // sweep follows the turn, a single map its chord between.
            let worst = (chosen.iter().step_by(7))
                .flat_map(|&a| chosen.iter().step_by(11).map(move |&b| (a, b)))
                .filter(|(a, b)| a != b)
                .map(|(a, b)| (q[a].distance(q[b]) / p[a].distance(p[b]) - 1.0).abs())
                .fold(0.0, f64::max);
            if phase == 1.0 || sweep {
                assert!(worst < 0.01, "sweep {sweep} phase {phase}: {worst}");
            }
            if phase == 1.0 {
                assert!(worst < 1e-5, "sweep {sweep}: {worst}");
            }
            // No face of the handle inside out, at any phase.
            for t in &inside {
                let [a, b, c] = t.map(|v| v as usize);
                let n0 = (p[b] - p[a]).cross(p[c] - p[a]);
                let n1 = (q[b] - q[a]).cross(q[c] - q[a]);
                assert!(n0.dot(n1) > 0.0, "sweep {sweep} phase {phase}: face {t:?}");
            }
            let inside_ids: Vec<u32> = (0..tris.len() as u32)
                .filter(|&f| tris[f as usize].iter().all(|&v| p[v as usize].x >= 1.0))
                .collect();
            assert!(
                report
                    .diagnostics
                    .inside_out
                    .iter()
                    .all(|f| inside_ids.binary_search(f).is_err()),
                "a face of the handle reported inside out"
            );
            // The handle's far samples act through the rigid part: not
            // "far from every vertex it acts on" (the blend's region lost
            // the handle's vertices), nor a cut at the handle's edge.
            let kinds: Vec<&str> = report
                .diagnostics
                .warnings
                .iter()
                .map(|w| w.kind())
                .collect();
            assert!(
                !kinds.contains(&"starts_far_from_mesh")
                    && !kinds.contains(&"support_crosses_region"),
                "sweep {sweep} phase {phase}: {kinds:?}"
            );
            // The anchor holds.
            let held_move = held
                .iter()
                .map(|&i| q[i].distance(p[i]))
                .fold(0.0, f64::max);
            assert!(
                held_move <= 1e-4 * diagonal,
                "sweep {sweep} phase {phase}: {held_move}"
            );
            // The chosen vertices land where the turn puts them at full phase.
            if phase == 1.0 {
                let turn = glam::DQuat::from_axis_angle(DVec3::Z, 75f64.to_radians());
                let off = (chosen.iter())
                    .map(|&i| q[i].distance(DVec3::X + turn * (p[i] - DVec3::X)))
                    .fold(0.0, f64::max);
                assert!(off < 1e-5 * diagonal, "sweep {sweep}: {off}");
            }
            // The session (the studio's and Blender's Live) and the saved
            // file give the same positions.
            let mut session = crate::Session::new(&mesh);
            let live = session
                .update_positions(&mesh, &file, phase)
                .expect("session")
                .to_vec();
            assert_eq!(live, moved.positions, "sweep {sweep} phase {phase}");
            let again = ControlFile::parse(&file.to_text()).expect("saved");
            let mut replayed = mesh.clone();
            crate::apply::deform_mesh(&mut replayed, &again, phase).expect("deform");
            assert_eq!(replayed.positions, moved.positions);
        }
    }
}
