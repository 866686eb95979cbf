//! Volume meshes morphed: every node moved by a control document's map
//! ([`morph_volume`]) or by a boundary-driven morph ([`morph_boundary`]),
//! and every cell checked exactly ([`check_cells`]).
//!
//! A cell is inside out when one of its corner determinants
//! ([`csrbf_mesh::volume::quality`]) is not positive: the count is exact
//! for the positions given (f64 signed volumes of the mapped corners, not
//! a sample of the map's Jacobian). Along the morph, each node moves on a
//! straight line from rest (a single map, or maps added, at phase s moves
//! a node by s times its displacement), so each corner determinant is a
//! cubic in s and the phase where the first cell turns is its first root
//! ([`csrbf::first_nonpositive`]); chained maps and sweeps are scanned and
//! bisected instead.

use std::path::Path;
use std::time::Instant;

use csrbf::{Combine, FittedStage};
use csrbf_mesh::volume::{CellKind, VolumeMesh, quality};
use glam::DVec3;
use rayon::prelude::*;
use serde_json::{Value, json};

use crate::report::LISTED;
use crate::{ControlFile, EditError, Note};

/// What the cells are like after a morph, and from which phase it turns
/// one inside out.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct CellCheck {
    /// 3D cells checked (triangles, quads, lines and vertices are
    /// boundaries, not judged).
    pub cells: usize,
    /// Cells inside out or flat after the morph that were not before it,
    /// ascending.
    pub inverted: Vec<u32>,
    /// Cells already inside out or flat at rest (not counted in
    /// `inverted`).
    pub inverted_at_rest: Vec<u32>,
    /// The first phase in (0, 1] of the morph at which a cell turns inside
    /// out, when one does.
    pub first_inversion: Option<f64>,
    /// The cell that turns first.
    pub first_inverted_cell: Option<u32>,
    /// The least scaled Jacobian at rest (1 ideal, 0 flat, below 0 inside
    /// out; +inf without 3D cells).
    pub min_scaled_jacobian_before: f64,
    /// The least scaled Jacobian after the morph.
    pub min_scaled_jacobian_after: f64,
    /// The same figures per zone of 3D cells.
    pub zones: Vec<ZoneCheck>,
}

/// A zone's part of a [`CellCheck`].
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ZoneCheck {
    /// The zone's name.
    pub name: String,
    /// Its 3D cells.
    pub cells: usize,
    /// Of them, turned inside out by the morph.
    pub inverted: usize,
    /// Its least scaled Jacobian after the morph.
    pub min_scaled_jacobian_after: f64,
}

/// The nodes of cell `c` at `points`.
fn corners_at(mesh: &VolumeMesh, c: usize, points: &[DVec3], out: &mut [DVec3; 8]) -> CellKind {
    for (k, &v) in mesh.cells.cell(c).iter().enumerate() {
        out[k] = points[v as usize];
    }
    mesh.cells.kinds[c]
}

/// Per cell: (least corner det at rest, after, scaled Jacobian before,
/// after, the first phase where a corner turns along the straight paths).
fn judge(mesh: &VolumeMesh, rest: &[DVec3], moved: &[DVec3], straight: bool) -> Vec<[f64; 5]> {
    (0..mesh.cells.len())
        .into_par_iter()
        .map(|c| {
            let (mut a, mut b) = ([DVec3::ZERO; 8], [DVec3::ZERO; 8]);
            let kind = corners_at(mesh, c, rest, &mut a);
            corners_at(mesh, c, moved, &mut b);
            let n = kind.nodes();
            let (a, b) = (&a[..n], &b[..n]);
            let mut first = f64::INFINITY;
            if straight {
                for &[o, x, y, z] in quality::corners(kind) {
                    let e = [a[x] - a[o], a[y] - a[o], a[z] - a[o]];
                    let f = [b[x] - b[o] - e[0], b[y] - b[o] - e[1], b[z] - b[o] - e[2]];
                    if let Some(s) = csrbf::first_nonpositive(quality::det_cubic(e, f)) {
                        first = first.min(s);
                    }
                }
            }
            [
                quality::min_corner_det(kind, a),
                quality::min_corner_det(kind, b),
                quality::scaled_jacobian(kind, a),
                quality::scaled_jacobian(kind, b),
                first,
            ]
        })
        .collect()
}

/// The cells of `mesh` checked at `moved` against `rest`: inside-out
/// counts, the least scaled Jacobians, per zone, and the first phase of
/// the straight-line morph from `rest` to `moved` at which a cell turns
/// (exact: each corner's determinant is a cubic in the phase).
///
/// Refused when `rest` or `moved` is not one position a node.
pub fn check_cells(
    mesh: &VolumeMesh,
    rest: &[DVec3],
    moved: &[DVec3],
) -> Result<CellCheck, EditError> {
    let n = mesh.points.len();
    if rest.len() != n || moved.len() != n {
        return Err(EditError::Morph(format!(
            "check_cells: {} rest and {} moved positions for {n} nodes",
            rest.len(),
            moved.len()
        )));
    }
    Ok(check_cells_with(mesh, rest, moved, true))
}

fn check_cells_with(
    mesh: &VolumeMesh,
    rest: &[DVec3],
    moved: &[DVec3],
    straight: bool,
) -> CellCheck {
    let judged = judge(mesh, rest, moved, straight);
    let solid = |c: usize| mesh.cells.kinds[c].dim() == 3;
    let mut check = CellCheck {
        cells: 0,
        inverted: Vec::new(),
        inverted_at_rest: Vec::new(),
        first_inversion: None,
        first_inverted_cell: None,
        min_scaled_jacobian_before: f64::INFINITY,
        min_scaled_jacobian_after: f64::INFINITY,
        zones: Vec::new(),
    };
    for (c, &[before, after, sj_before, sj_after, first]) in judged.iter().enumerate() {
        if !solid(c) {
            continue;
        }
        check.cells += 1;
        check.min_scaled_jacobian_before = check.min_scaled_jacobian_before.min(sj_before);
        check.min_scaled_jacobian_after = check.min_scaled_jacobian_after.min(sj_after);
        // Not positive, NaN included (a node at a coordinate that is not
        // a number cannot make a valid cell).
        if !(before > 0.0) {
            check.inverted_at_rest.push(c as u32);
            continue;
        }
        if !(after > 0.0) {
            check.inverted.push(c as u32);
        }
        if first.is_finite() && check.first_inversion.is_none_or(|f| first < f) {
            check.first_inversion = Some(first);
            check.first_inverted_cell = Some(c as u32);
        }
    }
    for z in &mesh.zones {
        let cells: Vec<usize> = (0..mesh.cell_zones.len())
            .filter(|&c| mesh.cell_zones[c] == z.tag && solid(c))
            .collect();
        if cells.is_empty() {
            continue;
        }
        check.zones.push(ZoneCheck {
            name: z.name.clone(),
            cells: cells.len(),
            inverted: cells
                .iter()
                .filter(|&&c| judged[c][0] > 0.0 && !(judged[c][1] > 0.0))
                .count(),
            min_scaled_jacobian_after: cells
                .iter()
                .map(|&c| judged[c][3])
                .fold(f64::INFINITY, f64::min),
        });
    }
    check
}

impl CellCheck {
    /// The serialised form (`csrbf deform --json`'s `cells`, Python's
    /// `VolumeReport.to_dict()["cells"]`); lists keep their first 1000.
    pub fn to_json(&self) -> Value {
        let finite = |x: f64| x.is_finite().then_some(x);
        json!({
            "cells": self.cells,
            "inverted_cells": self.inverted.len(),
            "inverted": self.inverted.iter().take(LISTED).collect::<Vec<_>>(),
            "inverted_at_rest": self.inverted_at_rest.len(),
            "first_inversion": self.first_inversion,
            "first_inverted_cell": self.first_inverted_cell,
            "min_scaled_jacobian_before": finite(self.min_scaled_jacobian_before),
            "min_scaled_jacobian_after": finite(self.min_scaled_jacobian_after),
            "zones": self.zones.iter().map(|z| json!({
                "name": z.name,
                "cells": z.cells,
                "inverted": z.inverted,
                "min_scaled_jacobian_after": finite(z.min_scaled_jacobian_after),
            })).collect::<Vec<_>>(),
        })
    }

    /// One line for people.
    pub fn summary(&self) -> String {
        let sj = |x: f64| {
            if x.is_finite() {
                format!("{x:.3}")
            } else {
                "-".into()
            }
        };
        let mut s = format!(
            "{} cell(s) inside out of {}, least scaled Jacobian {} -> {}",
            self.inverted.len(),
            self.cells,
            sj(self.min_scaled_jacobian_before),
            sj(self.min_scaled_jacobian_after)
        );
        if let (Some(p), Some(c)) = (self.first_inversion, self.first_inverted_cell) {
            s += &format!(", the first (cell {c}) from phase {p:.4}");
        }
        if !self.inverted_at_rest.is_empty() {
            s += &format!(
                "; {} cell(s) were inside out or flat before the morph (first: cell {})",
                self.inverted_at_rest.len(),
                self.inverted_at_rest[0]
            );
        }
        s
    }
}

/// What a morph of a volume mesh did.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct VolumeReport {
    /// The mesh's nodes.
    pub nodes: usize,
    /// The phase asked for.
    pub phase: f64,
    /// Nodes moved by more than 1e-9 of the diagonal.
    pub moved: usize,
    /// The largest move and its node.
    pub largest_move: f64,
    /// The node that moved most.
    pub largest_move_node: usize,
    /// The control vectors the map was fitted to.
    pub controls: usize,
    /// For a boundary-driven morph: the boundary nodes prescribed, the
    /// largest distance from a prescribed node to where the map puts it
    /// before it is set there, and the selection's rounds.
    pub boundary: Option<BoundaryFigures>,
    /// The cells.
    pub cells: CellCheck,
    /// What to do about inverted cells, when some are.
    pub advice: String,
    /// For a boundary-driven morph that inverts cells: what was measured
    /// to keep every cell positive.
    pub remedies: Option<CellRemedies>,
    /// The milliseconds the fit took.
    pub fit_ms: f64,
    /// The milliseconds the morph and the check took.
    pub morph_ms: f64,
    /// Of them, the cell check's.
    pub check_ms: f64,
}

/// How a boundary-driven morph chose its controls.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BoundaryFigures {
    /// Nodes of moved zones.
    pub moved_nodes: usize,
    /// Nodes of held zones (not also moved).
    pub held_nodes: usize,
    /// The tolerance asked for (None: every boundary node a control).
    pub tolerance: Option<f64>,
    /// The largest distance between the map and a prescribed position.
    pub max_error: f64,
    /// Rounds of the greedy selection (1 with every node).
    pub rounds: usize,
    /// The nodes the map was fitted to, ascending (every prescribed node
    /// without a tolerance).
    pub control_nodes: Vec<u32>,
    /// The steps of a sweep (`"sweep": true`), None for the single map.
    pub sweep_steps: Option<usize>,
    /// Whether the sweep is certified to keep every cell positive at every
    /// phase (its steps' gradient bounds times the cells' conditioning
    /// below 1).
    pub certified: bool,
}

impl VolumeReport {
    /// The one serialised form.
    pub fn to_json(&self) -> Value {
        json!({
            "nodes": self.nodes,
            "phase": self.phase,
            "moved": self.moved,
            "largest_move": self.largest_move,
            "largest_move_node": self.largest_move_node,
            "controls": self.controls,
            "boundary": self.boundary.as_ref().map(|b| json!({
                "moved_nodes": b.moved_nodes,
                "held_nodes": b.held_nodes,
                "tolerance": b.tolerance,
                "max_error": b.max_error,
                "rounds": b.rounds,
                "control_nodes": b.control_nodes.iter().take(LISTED).collect::<Vec<_>>(),
                "sweep_steps": b.sweep_steps,
                "certified": b.certified,
            })),
            "cells": self.cells.to_json(),
            "advice": self.advice,
            "remedies": self.remedies.as_ref().map(|r| json!({
                "radius_scale": r.radius_scale,
                "radius": r.radius,
                "sweep_steps": r.sweep_steps,
                "tried_scales": r.tried_scales,
                "searched_ms": r.searched_ms,
            })),
            "fit_ms": self.fit_ms,
            "morph_ms": self.morph_ms,
            "check_ms": self.check_ms,
        })
    }

    /// One line for people.
    pub fn summary(&self) -> String {
        format!(
            "{} node(s) moved of {}, largest move {} (node {}); {}",
            self.moved,
            self.nodes,
            csrbf::plain_number(self.largest_move),
            self.largest_move_node,
            self.cells.summary()
        )
    }

    /// The report of a morph at `phase`: the cell check's first inversion
    /// (a share of the way to `moved`) becomes a phase of the document.
    fn new(mesh: &VolumeMesh, phase: f64, moved: &[DVec3], mut cells: CellCheck) -> VolumeReport {
        cells.first_inversion = cells.first_inversion.map(|s| s * phase);
        let diag = diagonal(&mesh.points);
        let (mut count, mut largest, mut at) = (0, 0.0f64, 0);
        for (i, (a, b)) in mesh.points.iter().zip(moved).enumerate() {
            let d = a.distance(*b);
            if d > 1e-9 * diag {
                count += 1;
            }
            if d > largest {
                (largest, at) = (d, i);
            }
        }
        let advice = advice(&cells);
        VolumeReport {
            nodes: mesh.points.len(),
            phase,
            moved: count,
            largest_move: largest,
            largest_move_node: at,
            controls: 0,
            boundary: None,
            cells,
            advice,
            remedies: None,
            fit_ms: 0.0,
            morph_ms: 0.0,
            check_ms: 0.0,
        }
    }
}

/// What keeps a boundary-driven morph's cells positive, measured on the
/// mesh: the smallest radius factor tried (1.5, 2, 3) whose single map
/// inverts none, and the certified sweep's steps, within a budget.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct CellRemedies {
    /// The radius factor that inverts none, when one tried does.
    pub radius_scale: Option<f64>,
    /// That radius.
    pub radius: Option<f64>,
    /// The steps of a sweep certified to keep every cell positive, when
    /// one was found.
    pub sweep_steps: Option<usize>,
    /// The factors tried, in order.
    pub tried_scales: Vec<f64>,
    /// The milliseconds the search took.
    pub searched_ms: f64,
}

impl CellRemedies {
    /// The advice as one sentence, or "" when nothing was found.
    pub fn advice(&self) -> String {
        let mut found = Vec::new();
        if let (Some(f), Some(r)) = (self.radius_scale, self.radius) {
            found.push(format!(
                "a radius {f}x as large ({}) inverts none",
                csrbf::plain_number(r)
            ));
        }
        if let Some(k) = self.sweep_steps {
            found.push(format!(
                "a sweep (\"sweep\": true) of {k} steps is certified to invert none at any phase"
            ));
        }
        if found.is_empty() {
            return String::new();
        }
        format!("measured: {}", found.join("; "))
    }
}

/// Radius factors the remedies try, smallest first.
const REMEDY_SCALES: [f64; 3] = [1.5, 2.0, 3.0];

/// The remedies of a boundary-driven morph whose cells turn: each radius
/// factor's map fitted to the prescribed nodes, moved and checked at
/// `phase`, then the certified sweep, while the time spent stays within
/// `budget_ms` (a trial begun is finished).
fn cell_remedies(
    mesh: &VolumeMesh,
    starts: &[DVec3],
    targets: &[DVec3],
    (nodes, disp): (&[u32], &[DVec3]),
    options: csrbf::FitOptions,
    phase: f64,
    budget_ms: f64,
) -> CellRemedies {
    let t = Instant::now();
    let spent = || t.elapsed().as_secs_f64() * 1e3;
    let mut r = CellRemedies {
        radius_scale: None,
        radius: None,
        sweep_steps: None,
        tried_scales: Vec::new(),
        searched_ms: 0.0,
    };
    for f in REMEDY_SCALES {
        if spent() > budget_ms {
            break;
        }
        r.tried_scales.push(f);
        let wider = options.with_radius(options.radius * f);
        let Ok(def) = csrbf::Deformation::fit(starts, targets, wider) else {
            continue;
        };
        let out = place(mesh, &def.displacements(&mesh.points), nodes, disp, phase);
        if check_cells_with(mesh, &mesh.points, &out, false)
            .inverted
            .is_empty()
        {
            r.radius_scale = Some(f);
            r.radius = Some(wider.radius);
            break;
        }
    }
    let deadline = t + std::time::Duration::from_secs_f64(budget_ms.max(0.0) / 1e3);
    if spent() <= budget_ms
        && let Ok(Some(steps)) =
            certified_sweep_until(mesh, starts, targets, options, Some(deadline))
    {
        r.sweep_steps = Some(steps.len());
    }
    r.searched_ms = spent();
    r
}

/// The nodes moved by `d` at `phase`, the prescribed ones set where they
/// were prescribed (a held one at its rest coordinates, bit for bit).
fn place(mesh: &VolumeMesh, d: &[DVec3], nodes: &[u32], disp: &[DVec3], phase: f64) -> Vec<DVec3> {
    let moved = mesh
        .points
        .iter()
        .zip(d)
        .map(|(p, d)| *p + *d * phase)
        .collect();
    prescribed_at(mesh, moved, nodes, disp, phase)
}

/// `out` with the prescribed nodes set where they were prescribed at
/// `phase` (a held one at its rest coordinates, bit for bit).
fn prescribed_at(
    mesh: &VolumeMesh,
    mut out: Vec<DVec3>,
    nodes: &[u32],
    disp: &[DVec3],
    phase: f64,
) -> Vec<DVec3> {
    for (&v, dv) in nodes.iter().zip(disp) {
        out[v as usize] = if *dv == DVec3::ZERO {
            mesh.points[v as usize]
        } else {
            mesh.points[v as usize] + *dv * phase
        };
    }
    out
}

/// What to try when cells turn.
fn advice(cells: &CellCheck) -> String {
    match cells.first_inversion {
        Some(p) if !cells.inverted.is_empty() => format!(
            "{} cell(s) turn inside out (the first, cell {}, from phase {p:.4}): a larger radius of support spreads the motion over more cells, a sweep (\"sweep\": true) keeps each step's map fold-free, or the morph may stop at phase {:.3}",
            cells.inverted.len(),
            cells.first_inverted_cell.unwrap_or(0),
            (p * 0.95).max(0.0)
        ),
        Some(p) => format!(
            "no cell is inside out at the end, but cell {} is on the way (from phase {p:.4}): a solver stepping through the morph would meet it",
            cells.first_inverted_cell.unwrap_or(0)
        ),
        None => String::new(),
    }
}

/// The length of the diagonal of the points' bounding box.
fn diagonal(points: &[DVec3]) -> f64 {
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    if points.is_empty() {
        0.0
    } else {
        (hi - lo).length()
    }
}

/// The boundary surface control documents are resolved on, and what an
/// editor shows of a volume mesh: the mesh's [`VolumeMesh::surface`]
/// (vertex i is node i), with a part for each zone of 3D cells too (its
/// cells' faces on the boundary), so that a region naming it is known.
pub fn editing_surface(mesh: &VolumeMesh) -> csrbf_mesh::Mesh {
    let mut surface = mesh.surface();
    let solid: Vec<_> = mesh.zones.iter().filter(|z| z.dim == 3).collect();
    if solid.is_empty() {
        return surface;
    }
    // The surface's faces start with the boundary's, in the same order.
    let boundary = mesh.boundary_faces();
    for z in solid {
        let faces = boundary
            .iter()
            .enumerate()
            .filter(|(_, (c, _))| mesh.cell_zones.get(*c as usize) == Some(&z.tag))
            .map(|(f, _)| f as u32)
            .collect();
        surface.parts.push(csrbf_mesh::Part {
            name: z.name.clone(),
            kind: csrbf_mesh::PartKind::Group,
            faces,
        });
    }
    surface
}

/// The nodes of the zone named `name` (or numbered), for regions naming a
/// zone.
fn zone_group(mesh: &VolumeMesh) -> impl Fn(&str) -> Option<Vec<u32>> + '_ {
    // Every zone's nodes once (a sweep asks at every step).
    let nodes: std::collections::HashMap<i32, Vec<u32>> = mesh
        .zones
        .iter()
        .map(|z| (z.tag, mesh.zone_nodes(z.tag)))
        .collect();
    move |name: &str| mesh.zone(name).and_then(|z| nodes.get(&z.tag).cloned())
}

/// Every node of `mesh` moved by the control document `file` at `phase`
/// (each deformation at its own phase times it), in f64, and every cell
/// checked. Handles, connected regions and parts are resolved on the
/// mesh's boundary surface ([`VolumeMesh::surface`]: vertex i is node i,
/// zones of boundary faces are its parts); a region naming a zone of
/// cells takes all their nodes. `source` names the document in messages.
pub fn morph_volume(
    mesh: &VolumeMesh,
    file: &ControlFile,
    source: &str,
    phase: f64,
    allow_large: bool,
    notes: &mut dyn FnMut(Note),
) -> Result<(Vec<DVec3>, VolumeReport), EditError> {
    if !(0.0..=1.0).contains(&phase) {
        return Err(EditError::Deform(csrbf::Error::BadPhase(phase)));
    }
    let surface = editing_surface(mesh);
    let edit = crate::fit(file, source, Some(&surface), allow_large, notes)?;
    let t = Instant::now();
    let stages: Vec<FittedStage> = edit
        .stages()
        .into_iter()
        .map(|s| {
            let p = s.phase * phase;
            s.with_phase(p)
        })
        .collect();
    let groups = zone_group(mesh);
    let moved = csrbf::compose_f64(&mesh.points, &stages, edit.combine, &groups)
        .map_err(EditError::Deform)?;
    let straight = stages.len() == 1 && stages[0].sweep.is_none() || edit.combine == Combine::Add;
    let checked = Instant::now();
    let mut cells = check_cells_with(mesh, &mesh.points, &moved, straight);
    if !straight {
        scan_first_inversion(mesh, &stages, edit.combine, &groups, &mut cells)?;
    }
    let mut report = VolumeReport::new(mesh, phase, &moved, cells);
    report.controls = edit.specs.iter().map(|s| s.starts.len()).sum();
    report.fit_ms = edit.fit_ms;
    report.morph_ms = t.elapsed().as_secs_f64() * 1e3;
    report.check_ms = checked.elapsed().as_secs_f64() * 1e3;
    Ok((moved, report))
}

/// The first inversion of chained maps or sweeps (whose nodes do not move
/// on straight lines): the phases scanned in 32 steps, then the first step
/// that turns a cell bisected 30 times.
fn scan_first_inversion(
    mesh: &VolumeMesh,
    stages: &[FittedStage],
    combine: Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    cells: &mut CellCheck,
) -> Result<(), EditError> {
    let at = |s: f64| -> Result<Vec<u32>, EditError> {
        let scaled: Vec<FittedStage> = stages
            .iter()
            .map(|st| {
                let p = st.phase * s;
                st.clone().with_phase(p)
            })
            .collect();
        let moved = csrbf::compose_f64(&mesh.points, &scaled, combine, groups)
            .map_err(EditError::Deform)?;
        Ok(check_cells_with(mesh, &mesh.points, &moved, false).inverted)
    };
    let mut lo = 0.0;
    for k in 1..=32 {
        let hi = k as f64 / 32.0;
        let turned = at(hi)?;
        if !turned.is_empty() {
            let (mut a, mut b, mut first) = (lo, hi, turned[0]);
            for _ in 0..30 {
                let m = 0.5 * (a + b);
                match at(m)?.first() {
                    Some(&c) => {
                        b = m;
                        first = c;
                    }
                    None => a = m,
                }
            }
            cells.first_inversion = Some(b);
            cells.first_inverted_cell = Some(first);
            return Ok(());
        }
        lo = hi;
    }
    cells.first_inversion = None;
    cells.first_inverted_cell = None;
    Ok(())
}

/// The path of a morph file beside `base` (relative names are taken from
/// the morph file's folder).
pub(crate) fn beside(base: &Path, name: &str) -> std::path::PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_owned()
    } else {
        base.parent().unwrap_or(Path::new(".")).join(p)
    }
}

/// How a zone of the boundary moves.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Motion {
    /// Turned, scaled and moved as one (a handle's motion: rotation about
    /// the pivot, scaling about it, then the translation; the pivot is the
    /// rotation's own or the centroid of the zone's nodes).
    Rigid(csrbf::handle::Handle),
    /// Per node, from a text file: lines `node dx dy dz` (commas or
    /// spaces; `#` comments), nodes by their 0-based index in the mesh.
    Displacements(std::path::PathBuf),
    /// By a control document's map, evaluated at the zone's nodes (an edit
    /// made on the surface carried to the volume's boundary).
    Controls(std::path::PathBuf),
}

/// A zone that moves.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ZoneMove {
    /// The zone's name or tag.
    pub zone: String,
    /// How it moves.
    pub motion: Motion,
}

/// A boundary-driven morph: named zones move, others are held, the interior
/// follows through one map fitted to the boundary nodes.
///
/// ```json
/// {"boundary": {"radius": 0.5, "kernel": "c2", "tolerance": 1e-4,
///   "move": [{"zone": "wing", "translate": [0, 0.02, 0]},
///            {"zone": "flap", "rotate": {"axis": [0, 0, 1], "angle_deg": 5, "pivot": [1, 0, 0]}},
///            {"zone": "skin", "displacements": "skin.txt"},
///            {"zone": "nose", "controls": "nose.json"}],
///   "hold": ["farfield", "symmetry"]}}
/// ```
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BoundaryMorph {
    /// The map's options (radius, kernel, polynomial).
    pub options: csrbf::FitOptions,
    /// With a tolerance, the controls are a subset of the boundary nodes
    /// chosen greedily until the map puts every prescribed node within it
    /// (in the mesh's units); without, every boundary node is a control.
    pub tolerance: Option<f64>,
    /// The zones that move, in order (a node in two takes the first).
    pub moves: Vec<ZoneMove>,
    /// The zones held fixed (a node also in a moved zone moves).
    pub hold: Vec<String>,
    /// Take the morph as a sweep of steps each certified to keep every
    /// cell positive (`"sweep": true`; [`certified_sweep`]).
    pub sweep: bool,
    /// Fit a zone's control file (`"controls"`) even past the memory limit
    /// (the CLI's `--allow-large`; not in the document).
    pub allow_large: bool,
    /// Where the document is (relative file names are taken beside it).
    pub source: std::path::PathBuf,
}

impl BoundaryMorph {
    /// Whether a parsed JSON document is a boundary-driven morph (its top
    /// level has `boundary`) rather than a control file.
    pub fn is_boundary(root: &Value) -> bool {
        root.get("boundary").is_some()
    }

    /// Reads a boundary-driven morph from its JSON; `source` is the
    /// document's path (relative file names are taken beside it).
    pub fn from_value(root: &Value, source: &Path) -> Result<BoundaryMorph, crate::ControlError> {
        use crate::controls::{err, number};
        let mut warnings = Vec::new();
        let top = root
            .as_object()
            .ok_or_else(|| err("(top level)", "expected a JSON object"))?;
        crate::controls::unknown_keys(top, &["boundary", "comment"], "", &mut warnings);
        let obj = top
            .get("boundary")
            .and_then(Value::as_object)
            .ok_or_else(|| err("boundary", "expected an object"))?;
        crate::controls::unknown_keys(
            obj,
            &[
                "radius",
                "kernel",
                "polynomial",
                "tolerance",
                "move",
                "hold",
                "sweep",
                "comment",
            ],
            "boundary",
            &mut warnings,
        );
        if let Some(w) = warnings.first() {
            // A misspelt key of a morph is refused: it would silently change
            // what moves.
            return Err(err("boundary", w.clone()));
        }
        let radius = number(obj.get("radius"), "boundary.radius")?.ok_or_else(|| {
            err(
                "boundary.radius",
                "missing: give the radius of support in the mesh's units",
            )
        })?;
        let text = |k: &str| -> Result<Option<&str>, crate::ControlError> {
            match obj.get(k) {
                None | Some(Value::Null) => Ok(None),
                Some(Value::String(s)) => Ok(Some(s)),
                Some(other) => Err(err(
                    &format!("boundary.{k}"),
                    format!("expected a string, found {other}"),
                )),
            }
        };
        let mut options = csrbf::FitOptions::new(radius);
        if let Some(k) = text("kernel")? {
            options = options.with_kernel(
                k.parse()
                    .map_err(|e: csrbf::NameError| err("boundary.kernel", e.to_string()))?,
            );
        }
        if let Some(p) = text("polynomial")? {
            options =
                options
                    .with_polynomial(p.parse().map_err(|e: csrbf::NameError| {
                        err("boundary.polynomial", e.to_string())
                    })?);
        }
        if !(radius > 0.0) {
            return Err(err(
                "boundary.radius",
                format!("must be a number > 0 in the mesh's units, got {radius}"),
            ));
        }
        let tolerance = number(obj.get("tolerance"), "boundary.tolerance")?;
        if let Some(t) = tolerance
            && !(t > 0.0)
        {
            return Err(err("boundary.tolerance", format!("must be > 0, got {t}")));
        }
        let list = |k: &str| -> Result<&[Value], crate::ControlError> {
            match obj.get(k) {
                None | Some(Value::Null) => Ok(&[]),
                Some(Value::Array(a)) => Ok(a),
                Some(other) => Err(err(
                    &format!("boundary.{k}"),
                    format!("expected a list, found {other}"),
                )),
            }
        };
        let mut moves = Vec::new();
        for (i, m) in list("move")?.iter().enumerate() {
            let at = format!("boundary.move[{i}]");
            let o = m.as_object().ok_or_else(|| {
                err(&at, "expected {\"zone\": name, and translate/rotate/scale, \"displacements\": file or \"controls\": file}")
            })?;
            let mut w = Vec::new();
            crate::controls::unknown_keys(
                o,
                &[
                    "zone",
                    "translate",
                    "rotate",
                    "scale",
                    "displacements",
                    "controls",
                    "comment",
                ],
                &at,
                &mut w,
            );
            if let Some(w) = w.first() {
                return Err(err(&at, w.clone()));
            }
            let zone = match o.get("zone") {
                Some(Value::String(s)) => s.clone(),
                Some(Value::Number(n)) => n.to_string(),
                _ => {
                    return Err(err(
                        &format!("{at}.zone"),
                        "missing: the name or tag of the zone that moves",
                    ));
                }
            };
            let file = |k: &str| -> Result<Option<std::path::PathBuf>, crate::ControlError> {
                match o.get(k) {
                    None | Some(Value::Null) => Ok(None),
                    Some(Value::String(s)) => Ok(Some(beside(source, s))),
                    Some(other) => Err(err(
                        &format!("{at}.{k}"),
                        format!("expected a file name, found {other}"),
                    )),
                }
            };
            let rigid = ["translate", "rotate", "scale"]
                .iter()
                .any(|k| o.get(*k).is_some_and(|v| !v.is_null()));
            let (disp, ctl) = (file("displacements")?, file("controls")?);
            let motion = match (rigid, disp, ctl) {
                (true, None, None) => {
                    // A rotation's unknown key is an error here (a boundary
                    // morph keeps no warnings).
                    let mut unknown = Vec::new();
                    let h = crate::controls::rigid_motion(
                        o,
                        &at,
                        &mut unknown,
                        csrbf::handle::Handle::new(csrbf::Region::All),
                    )?;
                    if let Some(w) = unknown.first() {
                        return Err(err(&format!("{at}.rotate"), w.clone()));
                    }
                    Motion::Rigid(h)
                }
                (false, Some(d), None) => Motion::Displacements(d),
                (false, None, Some(c)) => Motion::Controls(c),
                (false, None, None) => {
                    return Err(err(
                        &at,
                        "says no motion: give translate, rotate or scale, \"displacements\": file or \"controls\": file",
                    ));
                }
                _ => {
                    return Err(err(
                        &at,
                        "gives more than one kind of motion: a rigid motion (translate, rotate, scale), \"displacements\" or \"controls\", one of them",
                    ));
                }
            };
            moves.push(ZoneMove { zone, motion });
        }
        if moves.is_empty() {
            return Err(err("boundary.move", "missing: give the zones that move"));
        }
        let mut hold = Vec::new();
        for (i, h) in list("hold")?.iter().enumerate() {
            match h {
                Value::String(s) => hold.push(s.clone()),
                Value::Number(n) => hold.push(n.to_string()),
                other => {
                    return Err(err(
                        &format!("boundary.hold[{i}]"),
                        format!("expected a zone name, found {other}"),
                    ));
                }
            }
        }
        let sweep = match obj.get("sweep") {
            None | Some(Value::Null) | Some(Value::Bool(false)) => false,
            Some(Value::Bool(true)) => true,
            Some(other) => {
                return Err(err(
                    "boundary.sweep",
                    format!("expected true or false, found {other}"),
                ));
            }
        };
        Ok(BoundaryMorph {
            options,
            tolerance,
            moves,
            hold,
            sweep,
            allow_large: false,
            source: source.to_owned(),
        })
    }
}

/// A zone by name or tag, or an error listing the zones.
fn find_zone<'a>(
    mesh: &'a VolumeMesh,
    name: &str,
    at: &str,
) -> Result<&'a csrbf_mesh::volume::Zone, EditError> {
    mesh.zone(name).ok_or_else(|| {
        EditError::Morph(format!(
            "{at}: the mesh has no zone {name:?}; {}",
            mesh.zone_names()
        ))
    })
}

/// Per-node displacements from a text file: `node dx dy dz` a line.
fn read_displacements(
    path: &Path,
    nodes: usize,
) -> Result<std::collections::HashMap<u32, DVec3>, EditError> {
    let text = std::fs::read_to_string(path).map_err(|source| {
        EditError::Mesh(csrbf_mesh::MeshError::Io {
            path: path.to_owned(),
            source,
        })
    })?;
    let mut out = std::collections::HashMap::new();
    for (l, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let bad = |m: String| EditError::Morph(format!("{}:{}: {m}", path.display(), l + 1));
        let words: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|w| !w.is_empty())
            .collect();
        if words.len() != 4 {
            return Err(bad(format!(
                "expected `node dx dy dz`, found {} value(s)",
                words.len()
            )));
        }
        let node: u32 = words[0]
            .parse()
            .map_err(|_| bad(format!("{:?} is not a node index", words[0])))?;
        if node as usize >= nodes {
            return Err(bad(format!("node {node}, but the mesh has {nodes} nodes")));
        }
        let mut d = [0.0; 3];
        for k in 0..3 {
            d[k] = words[k + 1]
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| bad(format!("{:?} is not a finite number", words[k + 1])))?;
        }
        if out.insert(node, DVec3::from(d)).is_some() {
            return Err(bad(format!("node {node} is given twice")));
        }
    }
    Ok(out)
}

/// The prescribed boundary: nodes and their displacements (zero for held
/// ones), and how many are moved and held.
fn prescribe(
    mesh: &VolumeMesh,
    morph: &BoundaryMorph,
    notes: &mut dyn FnMut(Note),
) -> Result<(Vec<u32>, Vec<DVec3>, usize, usize), EditError> {
    let n = mesh.points.len();
    let mut given: Vec<Option<DVec3>> = vec![None; n];
    let mut moved = 0;
    for (i, m) in morph.moves.iter().enumerate() {
        let at = format!("{}: boundary.move[{i}]", morph.source.display());
        let zone = find_zone(mesh, &m.zone, &at)?;
        let nodes = mesh.zone_nodes(zone.tag);
        if nodes.is_empty() {
            return Err(EditError::Morph(format!(
                "{at}: zone {:?} has no cells",
                zone.name
            )));
        }
        let disp: Vec<DVec3> = match &m.motion {
            Motion::Rigid(h) => {
                let centroid = nodes
                    .iter()
                    .map(|&v| mesh.points[v as usize])
                    .sum::<DVec3>()
                    / nodes.len() as f64;
                let a = h.motion(centroid);
                nodes
                    .iter()
                    .map(|&v| {
                        let p = mesh.points[v as usize];
                        a.transform_point3(p) - p
                    })
                    .collect()
            }
            Motion::Displacements(path) => {
                let table = read_displacements(path, n)?;
                let missing: Vec<u32> = nodes
                    .iter()
                    .copied()
                    .filter(|v| !table.contains_key(v))
                    .collect();
                if let Some(v) = missing.first() {
                    return Err(EditError::Morph(format!(
                        "{}: gives no displacement for node {v} of zone {:?} ({} of its {} nodes missing)",
                        path.display(),
                        zone.name,
                        missing.len(),
                        nodes.len()
                    )));
                }
                nodes.iter().map(|v| table[v]).collect()
            }
            Motion::Controls(path) => {
                let file = read_controls(path)?;
                let surface = editing_surface(mesh);
                let edit = crate::fit(
                    &file,
                    &path.display().to_string(),
                    Some(&surface),
                    morph.allow_large,
                    notes,
                )?;
                let sub: Vec<DVec3> = nodes.iter().map(|&v| mesh.points[v as usize]).collect();
                let groups = zone_group(mesh);
                let out = csrbf::compose_f64(&sub, &edit.stages(), edit.combine, &|name| {
                    // A region naming a zone selects its nodes among these.
                    let all = groups(name)?;
                    Some(
                        nodes
                            .iter()
                            .enumerate()
                            .filter(|(_, v)| all.binary_search(v).is_ok())
                            .map(|(k, _)| k as u32)
                            .collect(),
                    )
                })
                .map_err(EditError::Deform)?;
                out.iter().zip(&sub).map(|(a, b)| *a - *b).collect()
            }
        };
        let mut twice = 0;
        for (&v, d) in nodes.iter().zip(disp) {
            match &mut given[v as usize] {
                Some(_) => twice += 1,
                slot => {
                    *slot = Some(d);
                    moved += 1;
                }
            }
        }
        if twice > 0 {
            notes(Note::Warning(format!(
                "{at}: {twice} node(s) of zone {:?} are in a zone moved before it and move as that one says",
                zone.name
            )));
        }
    }
    let mut held = 0;
    for (i, name) in morph.hold.iter().enumerate() {
        let at = format!("{}: boundary.hold[{i}]", morph.source.display());
        let zone = find_zone(mesh, name, &at)?;
        let nodes = mesh.zone_nodes(zone.tag);
        if nodes.is_empty() {
            return Err(EditError::Morph(format!(
                "{at}: zone {:?} has no cells",
                zone.name
            )));
        }
        for v in nodes {
            if given[v as usize].is_none() {
                given[v as usize] = Some(DVec3::ZERO);
                held += 1;
            }
        }
    }
    let (nodes, disp) = given
        .iter()
        .enumerate()
        .filter_map(|(v, d)| d.map(|d| (v as u32, d)))
        .unzip();
    Ok((nodes, disp, moved, held))
}

/// Every node of `mesh` moved by a boundary-driven morph at `phase`: the
/// moved zones' nodes land on their displacements and the held ones stay
/// (both exactly: the map interpolates them, and they are then set where
/// they were prescribed), the interior follows the map fitted to the
/// boundary nodes (all, or a subset chosen within the tolerance), and every
/// cell is checked.
pub fn morph_boundary(
    mesh: &VolumeMesh,
    morph: &BoundaryMorph,
    phase: f64,
    notes: &mut dyn FnMut(Note),
) -> Result<(Vec<DVec3>, VolumeReport), EditError> {
    if !(0.0..=1.0).contains(&phase) {
        return Err(EditError::Deform(csrbf::Error::BadPhase(phase)));
    }
    let t = Instant::now();
    let (nodes, disp, moved_nodes, held_nodes) = prescribe(mesh, morph, notes)?;
    let prescribed_ms = t.elapsed().as_secs_f64() * 1e3;
    let starts: Vec<DVec3> = nodes.iter().map(|&v| mesh.points[v as usize]).collect();
    let targets: Vec<DVec3> = starts.iter().zip(&disp).map(|(s, d)| *s + *d).collect();
    let at = morph.source.display().to_string();
    let engine = |source: csrbf::Error| EditError::Engine {
        at: at.clone(),
        source,
    };
    let (def, picked, rounds, max_error) = match morph.tolerance {
        None => {
            let def = csrbf::Deformation::fit(&starts, &targets, morph.options)
                .map_err(|e| engine(e.into()))?;
            let err = largest_error(&def, &starts, &disp);
            (def, (0..starts.len()).collect(), 1, err)
        }
        Some(tol) => {
            greedy_fit(&starts, &targets, &disp, morph.options, tol, notes).map_err(engine)?
        }
    };
    let controls = picked.len();
    notes(Note::Progress(format!(
        "{at}: {controls} of {} boundary nodes as controls ({moved_nodes} moved, {held_nodes} held; {prescribed_ms:.1} ms), {} round(s), largest miss {} ({:.1} ms)",
        starts.len(),
        rounds,
        csrbf::plain_number(max_error),
        t.elapsed().as_secs_f64() * 1e3 - prescribed_ms
    )));
    let sweep = if morph.sweep {
        // Every prescribed node a control: a subset would leave the others
        // to be set in place after the sweep, outside its certificate.
        if picked.len() < starts.len() {
            notes(Note::Progress(format!(
                "{at}: the sweep takes all {} boundary nodes as controls (a subset's other nodes would be set in place outside the certificate)",
                starts.len()
            )));
        }
        let (s, t) = (&starts[..], &targets[..]);
        let found = certified_sweep(mesh, s, t, morph.options).map_err(engine)?;
        match &found {
            Some(steps) => notes(Note::Progress(format!(
                "{at}: a sweep of {} step(s), each certified to keep every cell positive",
                steps.len()
            ))),
            None => notes(Note::Warning(format!(
                "{at}: no sweep of at most {} steps is certified to keep every cell positive (a cell is too thin for the motion, or inside out at rest): the single map is used and checked",
                csrbf::MAX_STEPS
            ))),
        }
        found
    } else {
        None
    };
    let fit_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    // The prescribed nodes exactly where they were prescribed (the map puts
    // them there to its solver's precision).
    let out = match &sweep {
        Some(steps) => prescribed_at(mesh, walk(steps, &mesh.points, phase), &nodes, &disp, phase),
        None => place(mesh, &def.displacements(&mesh.points), &nodes, &disp, phase),
    };
    if let Some(v) = out.iter().position(|p| !p.is_finite()) {
        return Err(EditError::Morph(format!(
            "{at}: the morph put node {v} at a coordinate that is not a finite number"
        )));
    }
    // A sweep's nodes do not move on straight lines: its certificate
    // speaks for the phases, the check for the end.
    let checked = Instant::now();
    let cells = check_cells_with(mesh, &mesh.points, &out, sweep.is_none());
    let check_ms = checked.elapsed().as_secs_f64() * 1e3;
    let mut report = VolumeReport::new(mesh, phase, &out, cells);
    report.controls = if sweep.is_some() {
        starts.len()
    } else {
        controls
    };
    report.boundary = Some(BoundaryFigures {
        moved_nodes,
        held_nodes,
        tolerance: morph.tolerance,
        max_error,
        rounds,
        control_nodes: {
            let mut chosen: Vec<u32> = if sweep.is_some() {
                nodes.clone()
            } else {
                picked.iter().map(|&i| nodes[i]).collect()
            };
            chosen.sort_unstable();
            chosen
        },
        sweep_steps: sweep.as_ref().map(Vec::len),
        certified: sweep.is_some(),
    });
    report.fit_ms = fit_ms;
    report.morph_ms = t.elapsed().as_secs_f64() * 1e3;
    report.check_ms = check_ms;
    if !report.cells.inverted.is_empty() && sweep.is_none() {
        // Measured, within about twice what the morph took (at least a second).
        let budget = (2.0 * (fit_ms + report.morph_ms)).max(1000.0);
        let (s, t): (Vec<DVec3>, Vec<DVec3>) =
            picked.iter().map(|&i| (starts[i], targets[i])).unzip();
        let r = cell_remedies(mesh, &s, &t, (&nodes, &disp), morph.options, phase, budget);
        let said = r.advice();
        if !said.is_empty() {
            report.advice = format!("{}; {said}", report.advice);
        }
        report.remedies = Some(r);
    }
    Ok((out, report))
}

/// The largest distance between the map's displacement and the
/// prescribed one at the boundary nodes.
fn largest_error(def: &csrbf::Deformation, starts: &[DVec3], disp: &[DVec3]) -> f64 {
    def.displacements(starts)
        .iter()
        .zip(disp)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0, f64::max)
}

/// The greedy selection of the RBF mesh-morphing literature: a spread
/// first set, then each round adds the nodes the map misses most (up to
/// half as many again as it has), until every prescribed node is within
/// `tol`. Returns the map, the controls chosen (indices), the rounds and
/// the largest miss.
fn greedy_fit(
    starts: &[DVec3],
    targets: &[DVec3],
    disp: &[DVec3],
    options: csrbf::FitOptions,
    tol: f64,
    notes: &mut dyn FnMut(Note),
) -> csrbf::Result<(csrbf::Deformation, Vec<usize>, usize, f64)> {
    let n = starts.len();
    let first = (n / 20).clamp(n.min(64), 2000.min(n));
    let mut chosen = vec![false; n];
    let mut picked: Vec<usize> = (0..first).map(|k| k * n / first.max(1)).collect();
    picked.dedup();
    for &i in &picked {
        chosen[i] = true;
    }
    let mut rounds = 0;
    loop {
        rounds += 1;
        let s: Vec<DVec3> = picked.iter().map(|&i| starts[i]).collect();
        let t: Vec<DVec3> = picked.iter().map(|&i| targets[i]).collect();
        let def = csrbf::Deformation::fit(&s, &t, options).map_err(csrbf::Error::from)?;
        let got = def.displacements(starts);
        let mut misses: Vec<(f64, usize)> = got
            .iter()
            .zip(disp)
            .enumerate()
            .filter(|(i, _)| !chosen[*i])
            .map(|(i, (a, b))| (a.distance(*b), i))
            .filter(|&(e, _)| e > tol)
            .collect();
        let worst = got
            .iter()
            .zip(disp)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0, f64::max);
        if misses.is_empty() || picked.len() == n {
            return Ok((def, picked, rounds, worst));
        }
        notes(Note::Progress(format!(
            "round {rounds}: {} controls, {} node(s) missed by more than {}",
            picked.len(),
            misses.len(),
            csrbf::plain_number(tol)
        )));
        misses.sort_by(|a, b| b.0.total_cmp(&a.0));
        let add = misses.len().min((picked.len() / 2).max(16));
        for &(_, i) in &misses[..add] {
            chosen[i] = true;
            picked.push(i);
        }
    }
}

/// What a volume mesh holds, as `csrbf info` prints it and Python's
/// `VolumeMesh.info()` returns it: nodes, cells by kind, zones with their
/// cells and nodes, bounds, and the cells' shape at rest (the least scaled
/// Jacobian, cells already inside out or flat).
pub fn describe(mesh: &VolumeMesh) -> Value {
    let rest = check_cells_with(mesh, &mesh.points, &mesh.points, false);
    let (lo, hi) = mesh.points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let finite = |x: f64| x.is_finite().then_some(x);
    let kinds: serde_json::Map<String, Value> = mesh
        .cells
        .counts()
        .into_iter()
        .map(|(k, n)| (k.name().to_owned(), json!(n)))
        .collect();
    json!({
        "nodes": mesh.points.len(),
        "cells": mesh.cells.len(),
        "cell_kinds": kinds,
        "bounds": if mesh.points.is_empty() { Value::Null } else { json!({"min": lo.to_array(), "max": hi.to_array()}) },
        "diagonal": diagonal(&mesh.points),
        "zones": mesh.zones.iter().map(|z| json!({
            "name": z.name,
            "tag": z.tag,
            "dim": z.dim,
            "cells": mesh.zone_cells(z.tag).len(),
            "nodes": mesh.zone_nodes(z.tag).len(),
        })).collect::<Vec<_>>(),
        "solid_cells": rest.cells,
        "min_scaled_jacobian": finite(rest.min_scaled_jacobian_before),
        "inverted_or_flat": rest.inverted_at_rest.len(),
        "first_inverted_or_flat": rest.inverted_at_rest.first(),
        "boundary_faces": mesh.boundary_faces().len(),
    })
}

/// The steps of a sweep applied one after the other at `phase` (step j
/// of k by clamp(phase k - j, 0, 1) of its map).
fn walk(steps: &[csrbf::Deformation], rest: &[DVec3], phase: f64) -> Vec<DVec3> {
    let mut p = rest.to_vec();
    for (j, step) in steps.iter().enumerate() {
        let f = csrbf::step_phase(phase, j, steps.len());
        if f > 0.0 {
            let d = step.displacements(&p);
            for (p, d) in p.iter_mut().zip(d) {
                *p += d * f;
            }
        }
    }
    p
}

/// The largest conditioning bound of the cells' corners at `points`:
/// ||E||_F^3 / (2 det E) over every corner's edge matrix E, an upper bound
/// of ||E||_F / sigma_min(E) (sigma_1 sigma_2 <= ||E||_F^2 / 2, so
/// sigma_min >= 2 det E / ||E||_F^2); +inf when a corner is flat or inside
/// out.
pub fn conditioning(mesh: &VolumeMesh, points: &[DVec3]) -> f64 {
    (0..mesh.cells.len())
        .into_par_iter()
        .map(|c| {
            let mut p = [DVec3::ZERO; 8];
            let kind = corners_at(mesh, c, points, &mut p);
            let mut worst = 0.0f64;
            for &[o, a, b, cc] in quality::corners(kind) {
                let e = [p[a] - p[o], p[b] - p[o], p[cc] - p[o]];
                let det = quality::det3(e[0], e[1], e[2]);
                let f2: f64 = e.iter().map(|v| v.length_squared()).sum();
                let k = if det > 0.0 {
                    f2 * f2.sqrt() / (2.0 * det)
                } else {
                    f64::INFINITY
                };
                worst = worst.max(k);
            }
            worst
        })
        .reduce(|| 0.0, f64::max)
}

/// A sweep from `starts` to `targets` (straight paths) whose every step is
/// certified to keep every cell of `mesh` positive at every phase: a step
/// whose map has |dD/dx| <= L moves each edge e of a corner by at most
/// L |e| (along the edge, the map's change is its gradient's integral), so
/// a corner's edge matrix E becomes E (I + F) with ||F|| <= L ||E||_F /
/// sigma_min(E), and stays invertible with positive determinant at every
/// fraction of the step when that is below 1. The cells' shapes are taken
/// at the start of each step (they change as the sweep goes). None when no
/// sweep of at most `MAX_STEPS` steps is certified.
pub fn certified_sweep(
    mesh: &VolumeMesh,
    starts: &[DVec3],
    targets: &[DVec3],
    options: csrbf::FitOptions,
) -> csrbf::Result<Option<Vec<csrbf::Deformation>>> {
    certified_sweep_until(mesh, starts, targets, options, None)
}

/// [`certified_sweep`], giving up (None) once `deadline` has passed.
fn certified_sweep_until(
    mesh: &VolumeMesh,
    starts: &[DVec3],
    targets: &[DVec3],
    options: csrbf::FitOptions,
    deadline: Option<Instant>,
) -> csrbf::Result<Option<Vec<csrbf::Deformation>>> {
    const AIM: f64 = 0.8;
    let late = || deadline.is_some_and(|d| Instant::now() > d);
    let rest_kappa = conditioning(mesh, &mesh.points);
    if !rest_kappa.is_finite() {
        return Ok(None);
    }
    let fitted = Instant::now();
    let plain = csrbf::Deformation::fit(starts, targets, options)?;
    let fit_time = fitted.elapsed();
    let mut k = ((plain.gradient_bound() * rest_kappa / AIM).ceil() as usize).max(1);
    // A sweep fits every step before it is walked: past the deadline by
    // the estimate already, it is not begun.
    if deadline.is_some_and(|d| Instant::now() + fit_time * k.min(csrbf::MAX_STEPS) as u32 > d) {
        return Ok(None);
    }
    loop {
        if k > csrbf::MAX_STEPS || late() {
            return Ok(None);
        }
        let sweep = csrbf::Sweep::fit(
            starts,
            targets,
            &csrbf::Paths::default(),
            options,
            csrbf::SweepOptions::default().with_steps(Some(k)),
        )?;
        let mut p = mesh.points.clone();
        let mut worst = 0.0f64;
        for (step, bound) in sweep.steps.iter().zip(&sweep.bounds) {
            if late() {
                return Ok(None);
            }
            worst = worst.max(bound * conditioning(mesh, &p));
            if worst >= 1.0 {
                break;
            }
            let d = step.displacements(&p);
            for (p, d) in p.iter_mut().zip(d) {
                *p += d;
            }
        }
        if worst < 1.0 {
            return Ok(Some(sweep.steps));
        }
        if k == csrbf::MAX_STEPS {
            return Ok(None);
        }
        let next = (k as f64 * worst.min(1e6) / AIM).ceil() as usize;
        k = next.max(k + k / 2 + 1).min(csrbf::MAX_STEPS);
    }
}

/// A control document by path, its problems named with it.
fn read_controls(path: &Path) -> Result<ControlFile, EditError> {
    let text = std::fs::read_to_string(path).map_err(|source| {
        EditError::Mesh(csrbf_mesh::MeshError::Io {
            path: path.to_owned(),
            source,
        })
    })?;
    ControlFile::parse(&text).map_err(|e| EditError::Morph(format!("{}: {e}", path.display())))
}

/// What a volume mesh is morphed by: a control document (every node by its
/// map) or a boundary-driven morph (a document with `boundary`). The one
/// place a front end's file or dict becomes a morph: the CLI's `deform`,
/// `render` and `bench`, Python's `morph_volume`.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub enum VolumeMorph {
    /// A control document and the name its messages give it.
    Controls(ControlFile, String),
    /// A boundary-driven morph.
    Boundary(BoundaryMorph),
}

impl VolumeMorph {
    /// A parsed JSON document, a boundary-driven morph when its top level
    /// has `boundary`, else a control file; `source` names it (and places
    /// a boundary morph's relative files).
    pub fn from_value(root: &Value, source: &Path) -> Result<VolumeMorph, EditError> {
        let named = |e: crate::ControlError| EditError::Morph(format!("{}: {e}", source.display()));
        if BoundaryMorph::is_boundary(root) {
            return BoundaryMorph::from_value(root, source)
                .map(VolumeMorph::Boundary)
                .map_err(named);
        }
        let file = ControlFile::from_value(root).map_err(named)?;
        Ok(VolumeMorph::Controls(file, source.display().to_string()))
    }

    /// A morph file (JSON), either kind.
    pub fn read(path: &Path) -> Result<VolumeMorph, EditError> {
        let text = std::fs::read_to_string(path).map_err(|source| {
            EditError::Mesh(csrbf_mesh::MeshError::Io {
                path: path.to_owned(),
                source,
            })
        })?;
        let root: Value = serde_json::from_str(crate::json::strip_bom(&text)).map_err(|e| {
            EditError::Morph(format!(
                "{}: line {}, column {}: invalid JSON: {}",
                path.display(),
                e.line(),
                e.column(),
                crate::json::message_without_place(&e)
            ))
        })?;
        if let Err(e) = crate::json::check_duplicate_keys(&text) {
            return Err(EditError::Morph(format!(
                "{}: line {}: {e}",
                path.display(),
                e.second_line
            )));
        }
        VolumeMorph::from_value(&root, path)
    }

    /// What the document holds that its reader ignored (a control file's
    /// unknown keys; a boundary morph refuses them).
    pub fn warnings(&self) -> &[String] {
        match self {
            VolumeMorph::Controls(file, _) => &file.warnings,
            VolumeMorph::Boundary(_) => &[],
        }
    }

    /// Every node of `mesh` moved at `phase`, every cell checked
    /// ([`morph_volume`] or [`morph_boundary`]).
    pub fn run(
        &self,
        mesh: &VolumeMesh,
        phase: f64,
        allow_large: bool,
        notes: &mut dyn FnMut(Note),
    ) -> Result<(Vec<DVec3>, VolumeReport), EditError> {
        match self {
            VolumeMorph::Controls(file, source) => {
                morph_volume(mesh, file, source, phase, allow_large, notes)
            }
            VolumeMorph::Boundary(b) => {
                let mut b = b.clone();
                b.allow_large = allow_large;
                morph_boundary(mesh, &b, phase, notes)
            }
        }
    }
}

#[cfg(test)]
#[path = "volume_tests.rs"]
mod tests;
