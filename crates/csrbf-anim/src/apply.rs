//! The common cases in one call, for library users: deform a
//! [`csrbf_mesh::Mesh`] in place by a control file (handles sampled on it,
//! its deformations combined as the file says, normals carried by
//! `Mesh::move_vertices`), and save or load a fitted deformation by path.

use std::path::Path;

use csrbf::controls::ControlFile;
use csrbf::format::{self, Replay};
use csrbf::{Combine, DiagnoseOptions, Diagnostics, FittedStage, compose_diagnosed_with};
use csrbf_mesh::Mesh;
use glam::Vec3;

/// Meshes of at most this many triangles are searched for faces passing
/// through each other unless told otherwise ([`Checks::self_intersections`]).
/// See the README's figures for what the search costs.
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

/// What can go wrong in these calls.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ApplyError {
    /// The engine refused (the deformation's index names which one).
    #[error("deformation {index}")]
    Engine {
        /// Which deformation of the file.
        index: usize,
        /// Why.
        source: csrbf::Error,
    },
    /// Reading or writing a file.
    #[error(transparent)]
    Mesh(#[from] csrbf_mesh::MeshError),
    /// A replay file that does not decode.
    #[error("{}", path.display())]
    Replay {
        /// The file.
        path: std::path::PathBuf,
        /// Why.
        source: csrbf::Error,
    },
}

/// Fits every deformation of `file` on `mesh` (handles sampled on it,
/// connected regions measured along it).
pub fn fit_file(mesh: &Mesh, file: &ControlFile) -> Result<Vec<FittedStage>, ApplyError> {
    let lookup = |n: &str| mesh.part_vertices(n);
    let triangles = if file.deformations.iter().any(|s| s.region.needs_surface()) {
        mesh.faces.triangles()
    } else {
        Vec::new()
    };
    let mut out = Vec::with_capacity(file.deformations.len());
    for (index, spec) in file.deformations.iter().enumerate() {
        let engine = |source| ApplyError::Engine { index, source };
        let spec = spec
            .resolve_on(&mesh.positions, &triangles, &lookup)
            .map_err(engine)?;
        out.extend(spec.fit().map_err(engine)?);
    }
    Ok(out)
}

/// Deforms `mesh` in place by `file` at `phase` (each deformation at its own
/// phase times this one), recomputes its normals, and says what moved and
/// what may be wrong ([`Checks::default`]).
pub fn deform_mesh(
    mesh: &mut Mesh,
    file: &ControlFile,
    phase: f64,
) -> Result<Diagnostics, ApplyError> {
    deform_mesh_checked(mesh, file, phase, &Checks::default())
}

/// [`deform_mesh`], checked as `checks` says.
pub fn deform_mesh_checked(
    mesh: &mut Mesh,
    file: &ControlFile,
    phase: f64,
    checks: &Checks,
) -> Result<Diagnostics, ApplyError> {
    let stages: Vec<_> = fit_file(mesh, file)?
        .into_iter()
        .map(|s| {
            let scaled = s.phase * phase;
            s.with_phase(scaled)
        })
        .collect();
    let (moved, report) = compose_checked(mesh, &stages, file.combine, checks)
        .map_err(|source| ApplyError::Engine { index: 0, source })?;
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
) -> Result<(), ApplyError> {
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
pub fn load_replay(path: &Path) -> Result<Replay, ApplyError> {
    let bytes = std::fs::read(path).map_err(|source| csrbf_mesh::MeshError::Io {
        path: path.to_owned(),
        source,
    })?;
    format::decode(&bytes).map_err(|source| ApplyError::Replay {
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
        assert!(report.moved > 100 && report.flipped.is_empty());
        assert!(head.normals.as_ref().is_some_and(|n| n.len() == rest.len()));
        assert_ne!(head.positions, rest);
        let dir = std::env::temp_dir().join(format!("csrbf-apply-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("smile.csrbf");
        let stages = fit_file(
            &csrbf_mesh::read(&root.join("assets/models/cgal_head.off")).expect("head"),
            &file,
        )
        .expect("fit");
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
