//! Times the diagnostics against the deformation alone, for the figure of
//! issue 6 (diagnostics <= 10 % of a deform):
//! `cargo run --release --example bench_diagnose -p csrbf-anim -- MESH CONTROLS [RUNS]`.

use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (Some(mesh), Some(controls)) = (args.next(), args.next()) else {
        return Err("usage: diagnose MESH CONTROLS [RUNS]".into());
    };
    let runs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(7);
    let mesh = csrbf_mesh::read(mesh.as_ref())?;
    let file = csrbf_edit::controls::ControlFile::parse(&std::fs::read_to_string(&controls)?)?;
    let lookup = |n: &str| mesh.part_vertices(n);
    let mut stages = Vec::new();
    for spec in &file.deformations {
        let spec = spec.resolve(&mesh.positions, &lookup)?;
        let d = csrbf::Deformation::fit(&spec.starts, &spec.targets, spec.options)?;
        stages.push(
            csrbf::FittedStage::new(d)
                .with_region(spec.region.clone())
                .with_phase(spec.phase),
        );
    }
    let triangles = mesh.faces.triangles();
    let (mut plain, mut checked) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        let t = Instant::now();
        std::hint::black_box(csrbf::compose_with_groups(
            &mesh.positions,
            &stages,
            file.combine,
            &lookup,
        )?);
        plain.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        std::hint::black_box(csrbf::compose_diagnosed(
            &mesh.positions,
            &stages,
            file.combine,
            &triangles,
            &lookup,
        )?);
        checked.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let (p, c) = (median(plain), median(checked));
    println!(
        "{} vertices, {} triangles: compose {p:.1} ms, compose + diagnostics {c:.1} ms (+{:.0} %), median of {runs}",
        mesh.positions.len(),
        triangles.len(),
        (c / p - 1.0) * 100.0
    );
    Ok(())
}
