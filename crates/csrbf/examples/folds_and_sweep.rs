//! An edit that folds, found exactly, and the fold-free sweep that makes
//! the same edit without folding. A long push of one point of a sheet
//! (most of R) turns faces inside out; the sweep goes there in steps, each
//! certified not to fold (its gradient bound below 1).
//!
//! `cargo run --release -p csrbf --example folds_and_sweep`

use csrbf::glam::DVec3;
use csrbf::synthetic::grid;
use csrbf::{
    Combine, Deformation, FitOptions, FittedStage, Paths, Polynomial, Sweep, SweepOptions, folds,
};

fn main() -> Result<(), csrbf::Error> {
    let (rest, triangles) = grid(60);
    // The middle of the sheet pushed sideways by 80 % of R: the sheet folds.
    let starts = vec![DVec3::new(0.5, 0.5, 0.0)];
    let targets = vec![DVec3::new(0.74, 0.5, 0.0)];
    let options = FitOptions::new(0.3).with_polynomial(Polynomial::None);

    let plain = Deformation::fit(&starts, &targets, options)?;
    let found = folds(
        &rest,
        &triangles,
        &[FittedStage::new(plain)],
        Combine::Chain,
        &|_| None,
    )?;
    println!(
        "the single map: {} of {} triangles inside out, folding from phase {:?}",
        found.triangles.len(),
        triangles.len(),
        found.fold_phase
    );

    let sweep = Sweep::fit(
        &starts,
        &targets,
        &Paths::default(),
        options,
        SweepOptions::default(),
    )?;
    println!(
        "the sweep: {} steps, certified {}, worst step bound {:.3} (the single map's {:.3})",
        sweep.len(),
        sweep.certified(),
        sweep.bound(),
        sweep.plain_bound
    );
    // Its steps chained, each at full phase: no triangle turns over.
    let stages: Vec<FittedStage> = sweep.steps.iter().cloned().map(FittedStage::new).collect();
    let found = folds(&rest, &triangles, &stages, Combine::Chain, &|_| None)?;
    println!(
        "the sweep's result: {} triangles inside out",
        found.triangles.len()
    );
    Ok(())
}
