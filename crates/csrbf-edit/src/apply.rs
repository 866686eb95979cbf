//! The road's second half: fitted stages composed on a mesh at a phase
//! and checked ([`Edit::deform`], [`compose_report`]); a region checked
//! against the mesh it acts on; replay files by path; and the common case in
//! one call ([`deform_mesh`]).

use std::path::Path;
use std::time::Instant;

use csrbf::format::{self, Replay};
use csrbf::{Combine, DiagnoseOptions, Diagnostics, FittedStage, compose_diagnosed_with};
use csrbf_mesh::Mesh;
use glam::Vec3;

use crate::controls::ControlFile;
use crate::error::EditError;
use crate::fit::Edit;
use crate::remedy::{RemedySearch, remedies};
use crate::report::Report;

/// Meshes of at most this many triangles are searched for faces passing
/// through each other unless told otherwise ([`Checks::self_intersections`]).
/// See docs/performance.md and CHANGELOG.md for what the search costs.
pub const SELF_INTERSECTION_TRIANGLES: usize = 2_000_000;

/// What is checked of a deformed mesh beyond moves and folds.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[non_exhaustive]
pub struct Checks {
    /// The engine's options (the stretch limit; default 4).
    pub diagnose: DiagnoseOptions,
    /// Whether to look for faces passing through each other that did not
    /// at rest: `None` (default) for meshes of at most
    /// [`SELF_INTERSECTION_TRIANGLES`] triangles, `Some(true)` always,
    /// `Some(false)` never.
    pub self_intersections: Option<bool>,
}

impl Checks {
    /// With this stretch limit (a finite number >= 1).
    pub fn with_stretch_limit(mut self, limit: f64) -> Self {
        self.diagnose = self.diagnose.with_stretch_limit(limit);
        self
    }

    /// Self-intersections always (`Some(true)`), never, or by size (`None`).
    pub fn with_self_intersections(mut self, check: Option<bool>) -> Self {
        self.self_intersections = check;
        self
    }

    /// Whether a mesh of `triangles` triangles is searched.
    pub fn searches(&self, triangles: usize) -> bool {
        self.self_intersections
            .unwrap_or(triangles <= SELF_INTERSECTION_TRIANGLES)
    }
}

/// Deforms `mesh`'s positions by fitted `stages` (each at its own phase)
/// and diagnoses the result: the engine's figures (moves, folds, stretch)
/// and, as `checks` says, the faces that pass through each other in the
/// deformed mesh but not at rest (`csrbf_mesh::intersect`). The positions
/// are returned; the mesh is not changed.
pub fn compose_checked(
    mesh: &Mesh,
    stages: &[FittedStage],
    combine: Combine,
    checks: &Checks,
) -> Result<(Vec<Vec3>, Diagnostics), csrbf::Error> {
    let triangles = mesh.faces.triangles();
    let lookup = |n: &str| mesh.part_vertices(n);
    let (moved, mut report) = compose_diagnosed_with(
        &mesh.positions,
        stages,
        combine,
        &triangles,
        &lookup,
        &checks.diagnose,
    )?;
    if checks.searches(triangles.len()) {
        report.set_self_intersections(csrbf_mesh::intersect::new_self_intersections(
            &mesh.positions,
            &moved,
            &triangles,
        ));
    }
    Ok((moved, report))
}

/// Composes fitted `stages` on `mesh` at `phase` (each stage at its own
/// phase times this one) and checks the result ([`compose_checked`]): the
/// positions and the [`Report`] (without remedies: a replay has no control
/// document to change). `csrbf apply` and [`Edit::deform`] use it.
pub fn compose_report(
    mesh: &Mesh,
    stages: &[FittedStage],
    combine: Combine,
    phase: f64,
    checks: &Checks,
) -> Result<(Vec<Vec3>, Report), EditError> {
    let t = Instant::now();
    if !(0.0..=1.0).contains(&phase) {
        return Err(EditError::Deform(csrbf::Error::BadPhase(phase)));
    }
    let stages: Vec<FittedStage> = stages
        .iter()
        .map(|s| s.clone().with_phase(s.phase * phase))
        .collect();
    let (moved, diagnostics) =
        compose_checked(mesh, &stages, combine, checks).map_err(EditError::Deform)?;
    let mut report = Report::new(mesh.positions.len(), phase, diagnostics);
    report.deform_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok((moved, report))
}

impl Edit {
    /// The mesh's positions deformed at `phase` (each deformation at its own
    /// phase times this one) and checked as `checks` says, with the
    /// remedies searched as `search` says when a face turns inside out. The
    /// mesh is not changed ([`Mesh::move_vertices`] carries its normals to
    /// the positions given).
    pub fn deform(
        &self,
        mesh: &Mesh,
        phase: f64,
        checks: &Checks,
        search: RemedySearch,
    ) -> Result<(Vec<Vec3>, Report), EditError> {
        let (moved, mut report) =
            compose_report(mesh, &self.stages(), self.combine, phase, checks)?;
        report.fit_ms = self.fit_ms;
        if !report.diagnostics.inside_out.is_empty() && search != RemedySearch::Off {
            let triangles = mesh.faces.triangles();
            let lookup = |n: &str| mesh.part_vertices(n);
            // A search the engine cannot carry out (a radius past the memory
            // limit, say) leaves the report without remedies.
            report.remedies = remedies(
                &mesh.positions,
                &triangles,
                &self.specs,
                self.combine,
                phase,
                &lookup,
                search,
                self.fit_ms + report.deform_ms,
            )
            .ok();
        }
        Ok((moved, report))
    }
}

/// Deforms `mesh` in place by `file` at `phase` (each deformation at its own
/// phase times this one), carries its normals, and says what moved and
/// what may be wrong ([`Checks::default`], remedies bounded).
pub fn deform_mesh(mesh: &mut Mesh, file: &ControlFile, phase: f64) -> Result<Report, EditError> {
    deform_mesh_checked(mesh, file, phase, &Checks::default(), RemedySearch::Bounded)
}

/// [`deform_mesh`], checked as `checks` says and remedies searched as
/// `search` says.
pub fn deform_mesh_checked(
    mesh: &mut Mesh,
    file: &ControlFile,
    phase: f64,
    checks: &Checks,
    search: RemedySearch,
) -> Result<Report, EditError> {
    let edit = crate::fit(file, "controls", Some(mesh), false, &mut |_| {})?;
    let (moved, report) = edit.deform(mesh, phase, checks, search)?;
    // The file's normals carried through the move (seams and hard edges
    // kept), or recomputed when it had none.
    mesh.move_vertices(moved);
    Ok(report)
}

/// A region's parts and vertex indices checked against the mesh it will
/// act on, before any fit, so that a caller can name the control file and
/// deformation in the message (found when the mesh moves, it named only the
/// mesh): a part the mesh lacks (its parts listed) or a vertex beyond it.
pub fn check_region(region: &csrbf::Region, mesh: &Mesh) -> Result<(), String> {
    use csrbf::Region;
    let n = mesh.positions.len();
    match region {
        Region::Group(name) if mesh.part_vertices(name).is_none() => {
            let mut names: Vec<&str> = Vec::new();
            for p in &mesh.parts {
                if !names.contains(&p.name.as_str()) {
                    names.push(&p.name);
                }
            }
            let have = match names.len() {
                0 => "it has no named parts".to_owned(),
                1..=12 => format!("its parts: {}", names.join(", ")),
                k => format!("its parts: {} and {} more", names[..12].join(", "), k - 12),
            };
            Err(format!(
                "names part {name:?}, which the mesh does not have ({have})"
            ))
        }
        Region::Vertices(v) | Region::Weights { vertices: v, .. } => {
            match v.iter().find(|&&i| i as usize >= n) {
                Some(bad) => Err(format!(
                    "vertex {bad} is out of range: the mesh has {n} vertices (0 to {})",
                    n.saturating_sub(1)
                )),
                None => Ok(()),
            }
        }
        Region::Falloff { inner, .. } => check_region(inner, mesh),
        _ => Ok(()),
    }
}

/// Saves deformations fitted on `mesh` as a `.csrbf` file, whole or not at
/// all; when their regions list vertices by index, the file carries the
/// mesh's stamp ([`mesh_stamp`]) and `csrbf apply` refuses another mesh.
pub fn save_replay(
    path: &Path,
    stages: &[FittedStage],
    combine: csrbf::Combine,
    mesh: &Mesh,
) -> Result<(), EditError> {
    let stamp = Replay::lists_vertices(stages).then(|| mesh_stamp(mesh));
    Ok(csrbf_mesh::write_atomic(
        path,
        &format::encode_for(stages, combine, stamp),
    )?)
}

/// The stamp of `mesh` a `.csrbf` file carries when its regions list
/// vertices by index: its count of vertices and its faces' hash
/// ([`format::MeshStamp`]).
pub fn mesh_stamp(mesh: &Mesh) -> format::MeshStamp {
    format::MeshStamp::of(mesh.positions.len(), Some(mesh.faces.iter()))
}

/// Loads a `.csrbf` file.
pub fn load_replay(path: &Path) -> Result<Replay, EditError> {
    let bytes = std::fs::read(path).map_err(|source| csrbf_mesh::MeshError::Io {
        path: path.to_owned(),
        source,
    })?;
    format::decode(&bytes).map_err(|source| EditError::Replay {
        path: path.to_owned(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mesh_deforms_in_one_call_and_a_replay_round_trips() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut head = csrbf_mesh::read(&root.join("assets/models/cgal_head.off")).expect("head");
        let rest = head.positions.clone();
        let text =
            std::fs::read_to_string(root.join("assets/controls/head_smile.json")).expect("smile");
        let file = ControlFile::parse(&text).expect("controls");
        let report = deform_mesh(&mut head, &file, 1.0).expect("deform");
        assert!(report.diagnostics.moved > 100 && report.diagnostics.flipped.is_empty());
        assert!(head.normals.as_ref().is_some_and(|n| n.len() == rest.len()));
        assert_ne!(head.positions, rest);
        let dir = std::env::temp_dir().join(format!("csrbf-apply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("smile.csrbf");
        let rest_head = csrbf_mesh::read(&root.join("assets/models/cgal_head.off")).expect("head");
        let stages = crate::fit(&file, "smile", Some(&rest_head), false, &mut |_| {})
            .expect("fit")
            .stages();
        save_replay(&path, &stages, file.combine, &head).expect("save");
        let back = load_replay(&path).expect("load");
        assert_eq!(back.stages, stages);
        let e = load_replay(&dir.join("missing.csrbf")).expect_err("missing");
        assert!(e.to_string().contains("missing.csrbf"));
        // Regions checked against the mesh: a missing part names the parts,
        // a vertex past the end the count; inside a falloff too.
        use csrbf::Region;
        assert!(check_region(&Region::All, &head).is_ok());
        let far = Region::Vertices(vec![0, head.positions.len() as u32]);
        let said = check_region(&far, &head).expect_err("past the end");
        assert!(
            said.contains(&format!("has {} vertices", head.positions.len())),
            "{said}"
        );
        let nose = Region::Falloff {
            inner: Box::new(Region::Group("nose".into())),
            width: 0.1,
        };
        let said = check_region(&nose, &head).expect_err("no nose");
        assert!(
            said.contains("\"nose\"") && said.contains("no named parts"),
            "{said}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
