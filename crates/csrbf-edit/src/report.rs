//! What a deformation did to a mesh, with one serialised form every front
//! end reads.

use csrbf::Diagnostics;
use serde_json::{Value, json};

use crate::remedy::Remedies;

/// How many indices a list of faces or pairs keeps in the serialised form
/// (the counts are whole).
pub(crate) const LISTED: usize = 1000;

/// What a deformation did to a mesh: the engine's figures (moves, folds,
/// stretch, faces passing through each other, warnings) at the phase asked
/// for, the remedies when it folds, and the time it took. `csrbf deform`
/// prints it, `--json` prints [`Report::to_json`], Python's `Report` and
/// `to_dict()` are it, Blender's panel shows it.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Report {
    /// The mesh's vertices.
    pub vertices: usize,
    /// The phase asked for (each deformation at its own phase times it).
    pub phase: f64,
    /// The engine's figures at the phase asked for: its `fold_phase` (and
    /// the inside-out warning's) is the phase itself, of the one asked for
    /// (the engine gives a share of the phases it was given).
    pub diagnostics: Diagnostics,
    /// What would keep the edit from folding, when it folds and they were
    /// searched for.
    pub remedies: Option<Remedies>,
    /// The milliseconds the resolution and the fits took (0 for a replay).
    pub fit_ms: f64,
    /// The milliseconds the composition and the checks took.
    pub deform_ms: f64,
}

impl Report {
    /// A report of `diagnostics` of a mesh of `vertices` deformed at
    /// `phase` (each deformation at its own phase times it): the engine's
    /// fold phase, a share of the phases given, becomes the phase itself,
    /// in the figures and in the warning alike.
    pub fn new(vertices: usize, phase: f64, mut diagnostics: Diagnostics) -> Report {
        let scale = |p: &mut Option<f64>| *p = p.map(|s| s * phase);
        scale(&mut diagnostics.fold_phase);
        for w in &mut diagnostics.warnings {
            if let csrbf::Warning::InsideOut { fold_phase, .. } = w {
                scale(fold_phase);
            }
        }
        Report {
            vertices,
            phase,
            diagnostics,
            remedies: None,
            fit_ms: 0.0,
            deform_ms: 0.0,
        }
    }

    /// The phase (of the one asked for) at which the first face folds, or
    /// None when none does.
    pub fn fold_phase(&self) -> Option<f64> {
        self.diagnostics.fold_phase
    }

    /// The engine's warnings as sentences, in order (the remedies' advice
    /// is [`Report::advice`]).
    pub fn warnings(&self) -> Vec<String> {
        self.diagnostics
            .warnings
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    /// The remedies as one sentence ("to keep it from folding: ..."), or ""
    /// when there are none.
    pub fn advice(&self) -> String {
        self.remedies
            .as_ref()
            .map(Remedies::advice)
            .unwrap_or_default()
    }

    /// The one serialised form: what `csrbf deform --json` prints after the
    /// output's files, and Python's `Report.to_dict()`. Lists of faces keep
    /// their first 1000 (`LISTED`); counts are whole.
    pub fn to_json(&self) -> Value {
        let d = &self.diagnostics;
        let first = |v: &[u32]| v.iter().take(LISTED).copied().collect::<Vec<_>>();
        json!({
            "vertices": self.vertices,
            "phase": self.phase,
            "moved": d.moved,
            "largest_move": d.largest_move,
            "largest_move_vertex": d.largest_move_vertex,
            "inside_out_faces": d.inside_out.len(),
            "inside_out": first(&d.inside_out),
            "fold_phase": self.fold_phase(),
            "flipped_faces": d.flipped.len(),
            "flipped": first(&d.flipped),
            "largest_stretch": d.largest_stretch,
            "largest_stretch_face": d.largest_stretch_face,
            "stretch_limit": d.stretch_limit,
            "stretched_faces": d.stretched.len(),
            "stretched": first(&d.stretched),
            "self_intersections": d.self_intersections.as_ref().map(Vec::len),
            "self_intersecting": d
                .self_intersections
                .as_ref()
                .map(|p| p.iter().take(LISTED).collect::<Vec<_>>()),
            "warnings": self.warnings(),
            "warning_kinds": d.warnings.iter().map(|w| w.kind()).collect::<Vec<_>>(),
            "warning_controls": d.warnings.iter().map(warning_controls).collect::<Vec<_>>(),
            "fit_ms": self.fit_ms,
            "deform_ms": self.deform_ms,
            "remedies": self.remedies.as_ref().map(|r| json!({
                "radius_scale": r.radius_scale.map(|x| x.0),
                "radius_ms": r.radius_scale.map(|x| x.1),
                "sweep_steps": r.sweep.map(|x| x.0),
                "sweep_ms": r.sweep.map(|x| x.1),
                "sweep_untried": r.sweep_untried,
                "plain_ms": r.plain_ms,
                "searched_ms": r.searched_ms,
                "complete": r.complete,
                "advice": r.advice(),
            })),
        })
    }

    /// The figures as one line for people: "1487 vertices: 312 moved (...),
    /// largest move 0.02 (vertex 7), 0 face(s) inside out, largest stretch
    /// 1.3x (face 9), 0 face(s) over 4x, 0 pair(s) of faces newly
    /// intersecting".
    pub fn summary(&self) -> String {
        let d = &self.diagnostics;
        format!(
            "{} moved (by more than 1e-6 of the diagonal), largest move {}{}, {} face(s) inside out{}, {}, {}",
            d.moved,
            csrbf::plain_number(d.largest_move),
            d.largest_move_vertex
                .map(|v| format!(" (vertex {v})"))
                .unwrap_or_default(),
            d.inside_out.len(),
            self.fold_phase()
                .map(|p| format!(", folds from phase {p:.2} on"))
                .unwrap_or_default(),
            stretch_said(d),
            intersections_said(d),
        )
    }
}

/// The controls a warning names (its first few, by index in the layer's
/// control vectors), or None for a warning about faces or the whole map.
pub fn warning_controls(w: &csrbf::Warning) -> Option<&[usize]> {
    use csrbf::Warning;
    match w {
        Warning::PastFoldFreeBound { controls, .. }
        | Warning::StartsFarFromMesh { controls, .. }
        | Warning::SupportCrossesRegion { controls, .. } => Some(controls),
        _ => None,
    }
}

/// "largest stretch 1.32x (face 7), 0 face(s) over 4x".
fn stretch_said(r: &Diagnostics) -> String {
    format!(
        "largest stretch {}x{}, {} face(s) over {}x",
        csrbf::plain_number(r.largest_stretch),
        r.largest_stretch_face
            .map(|f| format!(" (face {f})"))
            .unwrap_or_default(),
        r.stretched.len(),
        r.stretch_limit
    )
}

/// "2 pair(s) of faces newly intersecting", or that it was not looked for.
fn intersections_said(r: &Diagnostics) -> String {
    match &r.self_intersections {
        Some(p) => format!("{} pair(s) of faces newly intersecting", p.len()),
        None => "self-intersections not checked".into(),
    }
}
