//! A pipeline of two deformations on regions, saved as a `.csrbf` replay and
//! replayed: what `csrbf fit` writes and `csrbf apply` reads. A change to one
//! stage recomputes only what depends on it.
//!
//! `cargo run --release -p csrbf --example pipeline_replay`

use csrbf::format::Replay;
use csrbf::glam::{DVec3, Vec3};
use csrbf::synthetic::grid;
use csrbf::{FitOptions, Pipeline, Region, Stage};

fn main() -> Result<(), csrbf::Error> {
    // A flat sheet of 101 x 101 points over [0, 1]^2.
    let (rest, _) = grid(100);

    // Stage 1: a bump in the middle, everywhere. Stage 2: a twist of the
    // left half only (a box region), applied to the bumped sheet.
    let bump = Stage::new(
        vec![DVec3::new(0.5, 0.5, 0.0)],
        vec![DVec3::new(0.5, 0.5, 0.15)],
        FitOptions::new(0.3),
    );
    let left = Region::Box {
        min: DVec3::new(-1.0, -1.0, -1.0),
        max: DVec3::new(0.5, 2.0, 1.0),
    };
    let twist = Stage::new(
        vec![DVec3::new(0.2, 0.2, 0.0), DVec3::new(0.2, 0.8, 0.0)],
        vec![DVec3::new(0.25, 0.2, 0.05), DVec3::new(0.15, 0.8, -0.05)],
        FitOptions::new(0.25),
    )
    .with_region(left);
    let mut pipeline = Pipeline::new(rest.clone());
    pipeline.push(bump);
    pipeline.push(twist);
    let out = pipeline.evaluate()?.to_vec();
    let highest = out.iter().map(|p| p.z).fold(f32::MIN, f32::max);
    println!("two stages: the sheet's highest point at z = {highest:.3}");

    // Half the bump: only stage 1's phase changes, nothing is refitted.
    pipeline.set_phase(0, 0.5)?;
    let half = pipeline.evaluate()?.to_vec();
    println!(
        "half the bump: z = {:.3}; systems built so far {}",
        half.iter().map(|p| p.z).fold(f32::MIN, f32::max),
        pipeline.work().systems
    );

    // Saved and replayed on the rest points: the same positions.
    let bytes = pipeline.to_replay()?.to_bytes();
    let replay = Replay::from_bytes(&bytes)?;
    let again: Vec<Vec3> = replay.compose(&rest, &|_| None)?;
    let worst = again
        .iter()
        .zip(&half)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    println!(
        "replay: {} bytes, {} stages, largest difference {worst:.2e}",
        bytes.len(),
        replay.stages.len()
    );
    Ok(())
}
