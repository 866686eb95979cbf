//! What a drag costs in the live preview: `cargo run --release -p
//! csrbf-studio --example live_drag -- MESH [STARTS] [RADIUS_SHARE]`.
//!
//! Places STARTS (default 200) control vectors on vertices spread over the
//! mesh, radius RADIUS_SHARE (default 0.1) of the diagonal, then times the
//! first update (factorisation, solve, composition, diagnostics, BVH refit)
//! and a drag step (a destination moved: solve, composition through the
//! bindings, refit; diagnostics wait for the release), medians of 7.

use std::path::PathBuf;
use std::time::Instant;

use csrbf::glam::DVec3;
use csrbf_studio::{Command, Document, History, Live};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = PathBuf::from(
        args.next()
            .ok_or("usage: live_drag MESH [STARTS] [RADIUS_SHARE]")?,
    );
    let starts: usize = args.next().map_or(Ok(200), |s| s.parse())?;
    let share: f64 = args.next().map_or(Ok(0.1), |s| s.parse())?;
    let mesh = csrbf_mesh::read(&path)?;
    let n = mesh.positions.len();
    let radius = mesh.diagonal() as f64 * share;
    let mut doc = Document::new(mesh, path, radius);
    let mut history = History::default();
    let stride = (n / starts.max(1)).max(1);
    for v in (0..n).step_by(stride).take(starts) {
        let p = doc.mesh.positions[v].as_dvec3();
        history.apply(&mut doc, Command::add(0, p, p))?;
    }
    let mut live = Live::new(&doc);
    let mut first = Vec::new();
    for _ in 0..7 {
        let mut fresh = Live::new(&doc);
        let t = Instant::now();
        fresh.update(&doc)?;
        first.push(t.elapsed().as_secs_f64() * 1e3);
    }
    live.update(&doc)?;
    let start = doc.controls.deformations[0].starts[0];
    let mut drag = Vec::new();
    history.begin_drag();
    for k in 1..=7 {
        let target = start + DVec3::splat(radius * 0.02 * k as f64);
        history.apply(
            &mut doc,
            Command::SetTarget {
                layer: 0,
                index: 0,
                target,
            },
        )?;
        let t = Instant::now();
        live.update_positions(&doc)?;
        drag.push(t.elapsed().as_secs_f64() * 1e3);
    }
    history.end_drag();
    println!(
        "{n} vertices, {} starts, R {share} of the diagonal: first update {:.1} ms, drag step {:.1} ms (medians of 7); factorisations {}",
        doc.controls.deformations[0].starts.len(),
        median(first),
        median(drag),
        live.factorisations()
    );
    Ok(())
}
