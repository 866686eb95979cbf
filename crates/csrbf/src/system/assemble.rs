//! Assembling A (profile or compressed columns) and choosing the solver.

use glam::DVec3;

use super::{Clock, FitOptions, FitPhases};
use crate::error::Result;
use crate::ordering::{self, Band, Chosen, Graph};
use crate::skyline::{Envelope, Profile};
use crate::solver::{Factor, SolverChoice};
use crate::symbolic::Permuted;

/// The band orderings' results: the band of the caller's order, the
/// ordering chosen, and its envelope (the profile solver's storage).
pub(super) struct Bands {
    pub(super) before: Band,
    pub(super) chosen: Chosen,
    pub(super) envelope: Envelope,
}

/// Below this many multiply-adds the profile factor takes a few
/// milliseconds at most: it is taken without trying the supernodal one.
const SKYLINE_SURE: f64 = 3e7;

/// Orders, chooses and runs the factorisation, timing its phases into
/// `phases` (from the ordering on) and its multiply-adds into `flops`;
/// gives back the band orderings made by `bands`. With `dissect_ahead` (a
/// large system likely to go to the supernodal solver) the dissection is
/// made and analysed beside `bands`, and A made from the order.
#[allow(clippy::too_many_arguments)] // the build's state, passed on once
pub(super) fn factor(
    starts: &[DVec3],
    graph: &Graph,
    bands: impl FnOnce() -> Bands + Send,
    dissect_ahead: bool,
    options: &FitOptions,
    phases: &mut FitPhases,
    flops: &mut f64,
) -> Result<(Factor, Bands), crate::error::FitError> {
    let mut clock = Clock::start();
    let kernel = options.kernel;
    let inv_r = 1.0 / options.radius;
    let phi = |i: usize, j: usize| kernel.eval(starts[i].distance(starts[j]) * inv_r);
    let diag = kernel.eval(0.0);
    let skyline = |bands: &Bands, phases: &mut FitPhases, mut clock: Clock| {
        let perm = bands.chosen.perm.clone();
        let profile = assemble_profile(graph, &perm, bands.envelope.clone(), &phi, diag);
        phases.assembly_ms += clock.lap();
        let factor = Factor::skyline(profile, perm);
        phases.numeric_ms = clock.lap();
        factor
    };
    // The supernodal factor of A (`a`) and its symbolic analysis,
    // unless the profile needs no more multiply-adds (counted from the
    // structure) and the solver is left to choose. Per multiply-add the
    // supernodal factorisation is the faster (measured 8-10 G/s against the
    // profile's 5-6 G/s on 2,000-10,000 starts), so at equal counts the
    // profile's lower overhead is all it gives up.
    let supernodal = |a: &Permuted,
                      symbolic,
                      bands: &Bands,
                      phases: &mut FitPhases,
                      flops: &mut f64,
                      mut clock: Clock| {
        let skyline_flops = bands.envelope.factor_flops();
        let supernodal_flops = Factor::supernodal_flops(&symbolic);
        if options.solver == SolverChoice::Auto && skyline_flops <= supernodal_flops {
            *flops = skyline_flops;
            return skyline(bands, phases, clock);
        }
        *flops = supernodal_flops;
        let factor = Factor::supernodal(symbolic, a);
        phases.numeric_ms = clock.lap();
        factor
    };
    if dissect_ahead {
        // The band orderings read the graph alone: they run beside the
        // dissection and the symbolic analysis after it, which reads the
        // graph and the order. A (its pattern and values, in the order) is
        // taken by whichever thread is free first, or a share of its values
        // each (the band orderings take about as long as the other two).
        let ((ordering_ms, symbolic, a), bands) = rayon::join(
            || {
                let mut clock = Clock::start();
                let order = ordering::geometric_dissection(graph, starts, options.radius);
                let inverse = ordering::inverse(&order);
                let ordering_ms = clock.lap();
                let (symbolic, a) = rayon::join(
                    || Factor::supernodal_symbolic(graph, Some(&order)),
                    || Permuted::of_graph(graph, &order, &inverse, &phi, diag),
                );
                (ordering_ms, symbolic, a)
            },
            bands,
        );
        // The dissection's own time; the rest, until all three are done,
        // the symbolic analysis's.
        phases.ordering_ms = ordering_ms;
        phases.symbolic_ms = clock.lap() - ordering_ms;
        let symbolic = symbolic?;
        if options.solver == SolverChoice::Auto && bands.envelope.factor_flops() < SKYLINE_SURE {
            *flops = bands.envelope.factor_flops();
            return skyline(&bands, phases, clock).map(|f| (f, bands));
        }
        let factor = supernodal(&a, symbolic, &bands, phases, flops, clock);
        return factor.map(|f| (f, bands));
    }
    let bands = bands();
    phases.ordering_ms = clock.lap();
    let skyline_flops = bands.envelope.factor_flops();
    *flops = skyline_flops;
    let choice = match options.solver {
        SolverChoice::Auto if skyline_flops < SKYLINE_SURE => SolverChoice::Skyline,
        SolverChoice::Auto => SolverChoice::Supernodal,
        c => c,
    };
    if choice == SolverChoice::Supernodal {
        let order = ordering::geometric_dissection(graph, starts, options.radius);
        let symbolic = Factor::supernodal_symbolic(graph, Some(&order))?;
        phases.symbolic_ms = clock.lap();
        let a = Permuted::of_graph(graph, symbolic.order(), symbolic.inverse(), &phi, diag);
        phases.assembly_ms = clock.lap();
        let factor = supernodal(&a, symbolic, &bands, phases, flops, clock);
        return factor.map(|f| (f, bands));
    }
    let factor = skyline(&bands, phases, clock);
    factor.map(|f| (f, bands))
}

/// A factor of the same structure as `previous` (same graph, ordering and
/// symbolic analysis) for new values: other start positions with the same
/// neighbours, or another kernel. Times assembly and numeric work.
pub(super) fn refactor(
    previous: &Factor,
    starts: &[DVec3],
    graph: &Graph,
    options: &FitOptions,
    phases: &mut FitPhases,
) -> Result<Factor, crate::error::FitError> {
    let mut clock = Clock::start();
    let kernel = options.kernel;
    let inv_r = 1.0 / options.radius;
    let phi = |i: usize, j: usize| kernel.eval(starts[i].distance(starts[j]) * inv_r);
    match previous {
        Factor::Skyline { profile, perm } => {
            let profile = assemble_profile(
                graph,
                perm,
                profile.envelope().clone(),
                &phi,
                kernel.eval(0.0),
            );
            phases.assembly_ms = clock.lap();
            let factor = Factor::skyline(profile, perm.clone());
            phases.numeric_ms = clock.lap();
            factor
        }
        Factor::Supernodal {
            symbolic, split, ..
        } => {
            let diag = kernel.eval(0.0);
            let a = Permuted::of_graph(graph, symbolic.order(), symbolic.inverse(), &phi, diag);
            phases.assembly_ms = clock.lap();
            let factor = Factor::supernodal_with(symbolic.clone(), split.clone(), &a);
            phases.numeric_ms = clock.lap();
            factor
        }
    }
}

fn assemble_profile(
    graph: &Graph,
    perm: &[u32],
    envelope: Envelope,
    phi: &impl Fn(usize, usize) -> f64,
    diag: f64,
) -> Profile {
    let inv = ordering::inverse(perm);
    let mut p = Profile::zeros(envelope);
    for (new, &old) in perm.iter().enumerate() {
        p.set(new, new, diag);
        for &j in graph.neighbours(old as usize) {
            let nj = inv[j as usize] as usize;
            if nj < new {
                p.set(new, nj, phi(old as usize, j as usize));
            }
        }
    }
    p
}
