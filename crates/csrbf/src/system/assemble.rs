//! Assembling A (profile or compressed columns) and choosing the solver.

use glam::DVec3;

use super::{Clock, FitOptions, FitPhases};
use crate::error::Result;
use crate::ordering::{self, Graph};
use crate::skyline::{Envelope, Profile};
use crate::solver::{Factor, LowerCsc, SolverChoice};

/// Chooses and runs the factorisation, timing its phases into `phases`;
/// `dissection`: the supernodal solver's ordering when made already.
#[allow(clippy::too_many_arguments)] // the build's state, passed on once
pub(super) fn factor(
    starts: &[DVec3],
    graph: &Graph,
    perm: Vec<u32>,
    envelope: Envelope,
    dissection: Option<Vec<u32>>,
    options: &FitOptions,
    phases: &mut FitPhases,
    flops: &mut f64,
) -> Result<Factor, crate::error::FitError> {
    let mut clock = Clock::start();
    let kernel = options.kernel;
    let inv_r = 1.0 / options.radius;
    let phi = |i: usize, j: usize| kernel.eval(starts[i].distance(starts[j]) * inv_r);
    let skyline_flops = envelope.factor_flops();
    *flops = skyline_flops;
    let choice = match options.solver {
        SolverChoice::Auto => {
            // Below some 30 million multiply-adds the profile factor takes a few
            // milliseconds at most; beyond, compare with the supernodal fill.
            if skyline_flops < 3e7 {
                SolverChoice::Skyline
            } else {
                SolverChoice::Supernodal
            }
        }
        c => c,
    };
    let skyline = |envelope, phases: &mut FitPhases, mut clock: Clock| {
        let profile = assemble_profile(graph, &perm, envelope, &phi, kernel.eval(0.0));
        phases.assembly_ms += clock.lap();
        let factor = Factor::skyline(profile, perm.clone());
        phases.numeric_ms = clock.lap();
        factor
    };
    if choice == SolverChoice::Supernodal {
        let a = lower_csc(graph, &phi, kernel.eval(0.0));
        phases.assembly_ms = clock.lap();
        let order = dissection
            .unwrap_or_else(|| ordering::geometric_dissection(graph, starts, options.radius));
        let symbolic = Factor::supernodal_symbolic(&a, Some(&order))?;
        phases.symbolic_ms = clock.lap();
        // Take the profile unless the supernodal factor needs fewer
        // multiply-adds (counted from its structure). Per multiply-add faer
        // is the faster (measured 8-10 G/s against the profile's 5-6 G/s on
        // 2,000-10,000 starts), so at equal counts the profile's lower
        // overhead is all it gives up.
        let supernodal_flops = Factor::supernodal_flops(&symbolic);
        if options.solver == SolverChoice::Auto && skyline_flops <= supernodal_flops {
            return skyline(envelope, phases, clock);
        }
        *flops = supernodal_flops;
        let factor = Factor::supernodal(symbolic, &a);
        phases.numeric_ms = clock.lap();
        return factor;
    }
    skyline(envelope, phases, clock)
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
            let a = lower_csc(graph, &phi, kernel.eval(0.0));
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

fn lower_csc(graph: &Graph, phi: &impl Fn(usize, usize) -> f64, diag: f64) -> LowerCsc {
    let n = graph.len();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::with_capacity(n + graph.edge_entries() / 2);
    let mut values = Vec::with_capacity(row_idx.capacity());
    col_ptr.push(0u32);
    for j in 0..n {
        row_idx.push(j as u32);
        values.push(diag);
        // Neighbour lists are sorted, so rows below the diagonal come in order.
        for &i in graph.neighbours(j).iter().filter(|&&i| i as usize > j) {
            row_idx.push(i);
            values.push(phi(i as usize, j));
        }
        col_ptr.push(row_idx.len() as u32);
    }
    LowerCsc {
        n,
        col_ptr,
        row_idx,
        values,
    }
}
