//! What a deformation did to a mesh, and what in it may be wrong: vertices
//! moved, faces turned over, control vectors past the fold-free bound,
//! starts that reach no vertex, empty regions, supports cut off by a
//! region's edge, and an affine part that moved vertices far from every
//! start (a local edit made global).
//!
//! ```
//! use csrbf::{Deformation, FitOptions, FittedStage, Polynomial, diagnose};
//! use glam::{DVec3, Vec3};
//!
//! let rest: Vec<Vec3> = (0..50).map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0)).collect();
//! let d = Deformation::fit(&[DVec3::new(2.0, 0.0, 0.0)], &[DVec3::new(2.0, 0.3, 0.0)],
//!     FitOptions::new(1.0).with_polynomial(Polynomial::None))?;
//! let stages = [FittedStage::new(d)];
//! let moved = csrbf::compose(&rest, &stages, csrbf::Combine::Chain)?;
//! let report = diagnose(&rest, &moved, &[], &stages, csrbf::Combine::Chain, &|_| None)?;
//! assert_eq!(report.moved, 19); // the points within R = 1 of x = 2
//! assert!(report.warnings.is_empty());
//! # Ok::<(), csrbf::Error>(())
//! ```

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering as AtomicOrdering};

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::deformation::Deformation;
use crate::error::number;
use crate::error::{Error, Result};
use crate::evaluate::{Blocks, PARALLEL_POINTS, Point, for_each_cell};
use crate::kernel::{Kernel, Polynomial};
use crate::octree::Octree;
use crate::region::Region;
use crate::stage::StageReach;

/// How many times its largest move a deformation's largest coefficient may
/// be before it is warned of as nearly singular. Well-posed edits stay far
/// below: starts 1 % of R apart pulling apart give coefficients a few
/// hundred times the move.
const ILL_CONDITIONED: f64 = 1e4;

/// How many control indices a warning lists before "and N more".
const LISTED: usize = 8;

/// Something about a deformation a user should know.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Warning {
    /// A deformation's region selects no vertex: it does nothing.
    EmptyRegion {
        /// Index of the deformation in the file.
        stage: usize,
        /// The region, in words.
        region: String,
    },
    /// Control vectors whose displacement, less the mean of their
    /// neighbours' (starts within R), is longer than the kernel's fold-free
    /// bound (see [`Kernel::fold_free_ratio`]): the map may fold near them.
    PastFoldFreeBound {
        /// Index of the deformation.
        stage: usize,
        /// The first few controls, by index.
        controls: Vec<usize>,
        /// How many.
        count: usize,
        /// The longest displacement (times the phase).
        longest: f64,
        /// The bound, fold_free_ratio x R.
        bound: f64,
        /// The kernel.
        kernel: Kernel,
    },
    /// Coefficients many thousand times the deformation's largest move: the
    /// system is nearly singular (typically a radius far larger than the
    /// model), so the map hangs on coefficients that cancel.
    IllConditioned {
        /// Index of the deformation.
        stage: usize,
        /// The largest coefficient over the largest move.
        amplification: f64,
        /// The radius of support.
        radius: f64,
        /// The diagonal of the vertices' bounding box.
        size: f64,
    },
    /// Starts farther than R from every vertex of the region: they move nothing.
    StartsFarFromMesh {
        /// Index of the deformation.
        stage: usize,
        /// The first few controls.
        controls: Vec<usize>,
        /// How many.
        count: usize,
        /// The radius of support.
        radius: f64,
        /// How far the nearest of the listed starts is from the vertices it
        /// acts on (a distance, in the mesh's units; infinite when it acts
        /// on none).
        nearest: f64,
    },
    /// Controls whose support reaches vertices outside the region: the map is
    /// cut off at the region's edge there (a seam may show).
    SupportCrossesRegion {
        /// Index of the deformation.
        stage: usize,
        /// The first few controls.
        controls: Vec<usize>,
        /// How many.
        count: usize,
    },
    /// Vertices farther than R from every start moved: only the linear
    /// polynomial can move them, so a local edit moved the whole model.
    PolynomialLeak {
        /// How many vertices.
        vertices: usize,
        /// The largest such move.
        largest: f64,
        /// One of them.
        example: u32,
    },
    /// Faces the map turns inside out (see [`Diagnostics::inside_out`]).
    InsideOut {
        /// How many.
        count: usize,
        /// The first few, by triangle index.
        triangles: Vec<u32>,
        /// The first phase at which a face folds ([`Diagnostics::fold_phase`]).
        fold_phase: Option<f64>,
    },
    /// Faces turned against their neighbours where the map does not fold
    /// (see [`Diagnostics::flipped`]): creases.
    FlippedFaces {
        /// How many.
        count: usize,
        /// The first few, by triangle index.
        triangles: Vec<u32>,
        /// Whether a deformation is nearly singular ([`Warning::IllConditioned`]):
        /// then a larger radius, the usual cure of a crease, is the wrong one.
        nearly_singular: bool,
    },
    /// Faces stretched more than the limit (see [`Diagnostics::stretched`]).
    Stretched {
        /// How many.
        count: usize,
        /// The first few, by triangle index.
        triangles: Vec<u32>,
        /// The largest stretch.
        largest: f64,
        /// The limit.
        limit: f64,
    },
    /// Faces that pass through each other where at rest they did not (see
    /// [`Diagnostics::self_intersections`]).
    SelfIntersecting {
        /// How many pairs.
        count: usize,
        /// The first few pairs, by triangle index.
        pairs: Vec<[u32; 2]>,
    },
}

impl Warning {
    /// A short stable name of the warning's kind, for callers that filter
    /// or act on kinds (the Python package's `Report.warning_kinds`, the
    /// Blender extension): `empty_region`, `past_fold_free_bound`,
    /// `ill_conditioned`, `starts_far_from_mesh`, `support_crosses_region`, `polynomial_leak`,
    /// `flipped_faces`, `inside_out`, `stretched`, `self_intersecting`.
    pub fn kind(&self) -> &'static str {
        match self {
            Warning::EmptyRegion { .. } => "empty_region",
            Warning::PastFoldFreeBound { .. } => "past_fold_free_bound",
            Warning::IllConditioned { .. } => "ill_conditioned",
            Warning::StartsFarFromMesh { .. } => "starts_far_from_mesh",
            Warning::SupportCrossesRegion { .. } => "support_crosses_region",
            Warning::PolynomialLeak { .. } => "polynomial_leak",
            Warning::FlippedFaces { .. } => "flipped_faces",
            Warning::InsideOut { .. } => "inside_out",
            Warning::Stretched { .. } => "stretched",
            Warning::SelfIntersecting { .. } => "self_intersecting",
        }
    }
}

fn list(v: &[usize], count: usize) -> String {
    let mut s = v
        .iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    if count > v.len() {
        s.push_str(&format!(" and {} more", count - v.len()));
    }
    s
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.numbered(Numbering::File).fmt(f)
    }
}

/// How a warning words deformations: the control file's (`deformation 0`)
/// or an editor's (`layer 0`, as the studio's panel names them). Either way
/// deformations and controls are numbered from 0, as the control file's
/// JSON paths number them (`deformations[1].controls[3]` is `deformation 1`,
/// `controls 3`): one rule for every front end. Mesh vertices and triangles
/// are indices too.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Numbering {
    /// `deformation 0`, `controls 3`: the file's words.
    File,
    /// `layer 0`, `controls 3`: an editor's words, the same numbers.
    Editor,
}

/// A warning as text in a [`Numbering`] ([`Warning::numbered`]).
#[derive(Clone, Copy, Debug)]
pub struct Numbered<'a> {
    warning: &'a Warning,
    numbering: Numbering,
}

impl Warning {
    /// The warning as text numbering deformations and controls as
    /// `numbering` says (its `Display` is [`Numbering::File`]).
    pub fn numbered(&self, numbering: Numbering) -> Numbered<'_> {
        Numbered {
            warning: self,
            numbering,
        }
    }
}

impl fmt::Display for Numbered<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (first, word) = match self.numbering {
            Numbering::File => (0, "deformation"),
            Numbering::Editor => (0, "layer"),
        };
        let stage = |s: &usize| format!("{word} {}", s + first);
        let controls = |v: &[usize], count: usize| {
            list(&v.iter().map(|i| i + first).collect::<Vec<_>>(), count)
        };
        match self.warning {
            Warning::EmptyRegion { stage: s, region } => write!(
                f,
                "{}: its region ({region}) holds no vertex, so it moves nothing",
                stage(s)
            ),
            Warning::PastFoldFreeBound {
                stage: s,
                controls: c,
                count,
                longest,
                bound,
                kernel,
            } => write!(
                f,
                "{}: {count} control vector(s) move farther from their neighbours than the fold-free bound of {kernel} ({:.3} R = {}; worst {}): controls {}; the surface may fold there: use a larger radius or shorter moves",
                stage(s),
                kernel.fold_free_ratio(),
                number(*bound),
                number(*longest),
                controls(c, *count)
            ),
            Warning::IllConditioned {
                stage: s,
                amplification,
                radius,
                size,
            } => write!(
                f,
                "{}: its coefficients reach {} times its largest move: the system is nearly singular (R = {} for a model {} across), so the map rests on coefficients that cancel (csrbf sums them in f64); a radius of at most a few times the model's size makes the same edit well posed",
                stage(s),
                number(*amplification),
                number(*radius),
                number(*size)
            ),
            Warning::StartsFarFromMesh {
                stage: s,
                controls: c,
                count,
                radius,
                nearest,
            } => write!(
                f,
                "{}: {count} start(s) lie farther than R = {} from every vertex it acts on{}, so they move nothing: controls {}",
                stage(s),
                number(*radius),
                if nearest.is_finite() && *count > c.len() {
                    format!(" (the nearest of those listed {} away)", number(*nearest))
                } else if nearest.is_finite() {
                    format!(" (the nearest {} away)", number(*nearest))
                } else {
                    String::new()
                },
                controls(c, *count)
            ),
            Warning::SupportCrossesRegion {
                stage: s,
                controls: c,
                count,
            } => write!(
                f,
                "{}: the support of {count} control(s) reaches past the region's edge, where the map is cut off (a seam may show): controls {}",
                stage(s),
                controls(c, *count)
            ),
            Warning::PolynomialLeak {
                vertices,
                largest,
                example,
            } => write!(
                f,
                "{vertices} vertices farther than R from every start moved (up to {}, e.g. vertex {example}): the linear polynomial made a local edit global; use \"polynomial\": \"none\" to keep it local",
                number(*largest)
            ),
            Warning::FlippedFaces {
                count,
                triangles,
                nearly_singular,
            } => write!(
                f,
                "{count} face(s) turned against the faces around them where the map itself does not fold (triangles {}): a sharp crease of the surface; {}",
                list(
                    &triangles.iter().map(|&t| t as usize).collect::<Vec<_>>(),
                    *count
                ),
                if *nearly_singular {
                    "the system is nearly singular (see above): a radius of at most a few times the model's size, not a larger one"
                } else {
                    "a larger radius smooths it"
                }
            ),
            Warning::InsideOut {
                count,
                triangles,
                fold_phase,
            } => write!(
                f,
                "{count} face(s) inside out (triangles {}): the map turns space over there{}; use a larger radius, shorter moves or more controls",
                list(
                    &triangles.iter().map(|&t| t as usize).collect::<Vec<_>>(),
                    *count
                ),
                fold_phase.map_or(String::new(), |p| format!(" from phase {p:.2} on"))
            ),
            Warning::Stretched {
                count,
                triangles,
                largest,
                limit,
            } => write!(
                f,
                "{count} face(s) stretched more than {}x (up to {}x; triangles {}): the texture and shading smear there; use a larger radius or more controls",
                number(*limit),
                number(*largest),
                list(
                    &triangles.iter().map(|&t| t as usize).collect::<Vec<_>>(),
                    *count
                )
            ),
            Warning::SelfIntersecting { count, pairs } => {
                let shown: Vec<String> = pairs.iter().map(|[a, b]| format!("{a}/{b}")).collect();
                write!(
                    f,
                    "{count} pair(s) of faces pass through each other where at rest they did not (triangles {}{}): the surface runs into itself",
                    shown.join(", "),
                    if *count > pairs.len() {
                        format!(" and {} more", count - pairs.len())
                    } else {
                        String::new()
                    }
                )
            }
        }
    }
}

/// The figures of one deformed mesh.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct Diagnostics {
    /// Vertices that moved (by more than 1e-6 of the rest diagonal).
    pub moved: usize,
    /// The largest move.
    pub largest_move: f64,
    /// The vertex that moved most.
    pub largest_move_vertex: Option<u32>,
    /// Triangles turned over: a face whose deformed normal points against
    /// the deformed normals of its corners (the surface around it) where at
    /// rest it did not. A rigid turn of a whole part flips nothing.
    pub flipped: Vec<u32>,
    /// Triangles the map turns inside out: det J <= 0 at their centroid
    /// (see [`crate::folds`]), ascending. The truth of a fold, where
    /// `flipped` sees only its crease.
    pub inside_out: Vec<u32>,
    /// The first phase in (0, 1] (a share of the phases given) at which
    /// some triangle folds; None when none does.
    pub fold_phase: Option<f64>,
    /// The largest stretch of a triangle: the largest singular value of the
    /// map from its rest shape to its deformed one, in its plane (see
    /// [`crate::face_stretches`]); 1 when no triangle grew.
    pub largest_stretch: f64,
    /// The triangle stretched most (None when none grew).
    pub largest_stretch_face: Option<u32>,
    /// Triangles stretched more than [`Diagnostics::stretch_limit`], ascending.
    pub stretched: Vec<u32>,
    /// The limit `stretched` was judged by ([`DiagnoseOptions::stretch_limit`]).
    pub stretch_limit: f64,
    /// Pairs of triangles `[i, j]` (i < j, ascending) that pass through each
    /// other in the deformed mesh but not at rest; None when not checked.
    /// The engine does not look (it knows no mesh structure to search
    /// with): `csrbf_mesh::intersect` does, and the callers that hold a mesh
    /// (the edit layer, `csrbf_edit::compose_checked`, so every front end) set it with
    /// [`Diagnostics::set_self_intersections`].
    pub self_intersections: Option<Vec<[u32; 2]>>,
    /// Everything worth a warning, in the order found.
    pub warnings: Vec<Warning>,
}

impl Diagnostics {
    /// Records the pairs of triangles that pass through each other in the
    /// deformed mesh but not at rest, with a warning when there are any.
    pub fn set_self_intersections(&mut self, pairs: Vec<[u32; 2]>) {
        self.warnings
            .retain(|w| !matches!(w, Warning::SelfIntersecting { .. }));
        if !pairs.is_empty() {
            self.warnings.push(Warning::SelfIntersecting {
                count: pairs.len(),
                pairs: pairs.iter().copied().take(LISTED).collect(),
            });
        }
        self.self_intersections = Some(pairs);
    }
}

/// What the diagnostics judge by.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct DiagnoseOptions {
    /// Triangles stretched more than this (a finite number >= 1) are listed
    /// and warned of; default [`crate::STRETCH_LIMIT`] (4).
    pub stretch_limit: f64,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        DiagnoseOptions {
            stretch_limit: crate::stretch::STRETCH_LIMIT,
        }
    }
}

impl DiagnoseOptions {
    /// With this stretch limit.
    pub fn with_stretch_limit(mut self, limit: f64) -> Self {
        self.stretch_limit = limit;
        self
    }

    /// Refuses a stretch limit that is not a finite number >= 1.
    pub fn check(&self) -> Result<()> {
        if !(self.stretch_limit >= 1.0 && self.stretch_limit.is_finite()) {
            return Err(Error::BadStretchLimit(self.stretch_limit));
        }
        Ok(())
    }
}

/// Diagnoses a deformed mesh: `rest` and `moved` positions, its `triangles`
/// (may be empty: no face checks), and the deformations that moved it, each
/// with its region and phase (as given to [`crate::compose`]). Regions and
/// reach are judged on the rest positions (for later stages of a chain this
/// is an approximation: [`compose_diagnosed`] judges each stage on the points
/// it moved, at no extra evaluation). `groups` resolves part names.
pub fn diagnose(
    rest: &[Vec3],
    moved: &[Vec3],
    triangles: &[[u32; 3]],
    stages: &[crate::FittedStage],
    combine: crate::Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<Diagnostics> {
    diagnose_with(
        rest,
        moved,
        (triangles, &DiagnoseOptions::default()),
        stages,
        combine,
        groups,
        None,
    )
}

/// [`crate::compose`] and [`diagnose`] in one: the reach of every start is
/// recorded while each stage is evaluated, so the diagnostics cost little
/// more than the faces' check.
pub fn compose_diagnosed(
    rest: &[Vec3],
    stages: &[crate::FittedStage],
    combine: crate::Combine,
    triangles: &[[u32; 3]],
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> Result<(Vec<Vec3>, Diagnostics)> {
    compose_diagnosed_with(
        rest,
        stages,
        combine,
        triangles,
        groups,
        &DiagnoseOptions::default(),
    )
}

/// [`compose_diagnosed`] judged by `options` (the stretch limit).
pub fn compose_diagnosed_with(
    rest: &[Vec3],
    stages: &[crate::FittedStage],
    combine: crate::Combine,
    triangles: &[[u32; 3]],
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    options: &DiagnoseOptions,
) -> Result<(Vec<Vec3>, Diagnostics)> {
    options.check()?;
    let mut traced = Vec::with_capacity(stages.len());
    let moved = crate::stage::compose_traced(rest, stages, combine, groups, Some(&mut traced))?;
    let report = diagnose_with(
        rest,
        &moved,
        (triangles, options),
        stages,
        combine,
        groups,
        Some(&traced),
    )?;
    Ok((moved, report))
}

fn diagnose_with(
    rest: &[Vec3],
    moved: &[Vec3],
    (triangles, options): (&[[u32; 3]], &DiagnoseOptions),
    stages: &[crate::FittedStage],
    combine: crate::Combine,
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    traced: Option<&[StageReach]>,
) -> Result<Diagnostics> {
    if moved.len() != rest.len() {
        return Err(Error::PointCount {
            what: "deformed points",
            expected: rest.len(),
            got: moved.len(),
        });
    }
    let (lo, hi) = rest.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let diagonal = if rest.is_empty() {
        0.0
    } else {
        (hi - lo).length() as f64
    };
    let tol = (diagonal * 1e-6).max(f64::MIN_POSITIVE);
    let moves: Vec<f64> = rest
        .par_iter()
        .zip(moved.par_iter())
        .with_min_len(4096)
        .map(|(a, b)| a.as_dvec3().distance(b.as_dvec3()))
        .collect();
    let moved_count = moves.iter().filter(|&&m| m > tol).count();
    let largest = moves
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .filter(|m| *m.1 > 0.0);

    let mut warnings = Vec::new();
    // Vertices within R of some start of a deformation acting on them.
    let mut near_any = vec![false; rest.len()];
    let mut any_linear = false;
    // The points of the rigid part just before (a handle's).
    let mut rigid_points: Vec<u32> = Vec::new();
    for (at, stage) in stages.iter().enumerate() {
        let (def, region, phase) = (&stage.deformation, &stage.region, &stage.applied_phase());
        // Warnings name the deformation as the user numbers them: a sweep's
        // steps are one deformation, and its first step speaks for it.
        let k = crate::stage::deformation_index(stages, at);
        let later_step = stage.sweep.is_some_and(|s| s.index > 0);
        any_linear |= def.polynomial() == Polynomial::Linear;
        let own;
        let seen: &StageReach = match traced {
            Some(t) => &t[at],
            None => {
                let selected = region.select(rest, groups)?;
                let inside: Vec<Vec3> = selected.iter().map(|&i| rest[i as usize]).collect();
                let (near, touched) = reach(def, &inside);
                own = StageReach {
                    selected,
                    near,
                    touched,
                };
                &own
            }
        };
        let (selected, near, touched) = (&seen.selected, &seen.near, &seen.touched);
        // A handle's rigid part moves its own points as one (an affine map:
        // no fold, no start out of reach to speak of); its deformation's
        // blend, the stage after it, is judged.
        if later_step || stage.rigid_part {
            for (&i, &x) in selected.iter().zip(near) {
                near_any[i as usize] |= x;
            }
            if stage.rigid_part {
                // Its points, and the ones it lists at weight 0 (an
                // anchor's, held still).
                rigid_points = match region {
                    Region::Weights { vertices, .. } => vertices.clone(),
                    _ => selected.clone(),
                };
            }
            continue;
        }
        // The blend after a rigid part meets it at the handle's points: no
        // cut there (its map matches the rigid part's at the samples).
        let joined = std::mem::take(&mut rigid_points);
        if selected.is_empty() {
            warnings.push(Warning::EmptyRegion {
                stage: k,
                region: region.to_string(),
            });
            continue;
        }
        // Control vectors past the fold-free bound, relative to their
        // neighbours' (a rigid motion of many starts is not a fold).
        let moves = def.displacements(def.starts());
        let lengths: Vec<f64> = moves.iter().map(|d| d.length() * phase).collect();
        let relative = relative_moves(def, &moves, *phase);
        let bound = def.kernel().fold_free_ratio() * def.radius();
        // A sweep's steps are certified where they are fitted.
        let over: Vec<usize> = (0..relative.len())
            .filter(|&j| relative[j] > bound && stage.sweep.is_none())
            .collect();
        if !over.is_empty() {
            warnings.push(Warning::PastFoldFreeBound {
                stage: k,
                controls: over.iter().copied().take(LISTED).collect(),
                count: over.len(),
                longest: over.iter().map(|&j| relative[j]).fold(0.0, f64::max),
                bound,
                kernel: def.kernel(),
            });
        }
        // Coefficients far past the moves: nearly singular.
        let largest_move = def.largest_move();
        let largest_coefficient = def
            .coefficients()
            .iter()
            .map(|a| a.length())
            .fold(0.0, f64::max);
        if largest_coefficient > ILL_CONDITIONED * largest_move && largest_move > 0.0 {
            warnings.push(Warning::IllConditioned {
                stage: k,
                amplification: largest_coefficient / largest_move,
                radius: def.radius(),
                size: diagonal,
            });
        }
        // Which starts reach a vertex of the region, which vertices a start.
        let all = selected.len() == rest.len();
        for (&i, &x) in selected.iter().zip(near) {
            near_any[i as usize] |= x;
        }
        // The blend's samples on the handle (and its anchor's pins) act
        // where the rigid part meets it: reaching those points is reaching.
        let met: Vec<bool> = if joined.is_empty() {
            Vec::new()
        } else {
            let points: Vec<Vec3> = joined.iter().map(|&i| rest[i as usize]).collect();
            reach(def, &points).1
        };
        let far: Vec<usize> = (0..touched.len())
            .filter(|&j| !touched[j] && !met.get(j).copied().unwrap_or(false))
            .collect();
        if !far.is_empty() {
            let listed: Vec<usize> = far.iter().copied().take(LISTED).collect();
            // How far off they are, for the user to weigh against R: the
            // listed few against every vertex acted on.
            let nearest = listed
                .iter()
                .flat_map(|&j| {
                    let start = def.starts()[j];
                    selected
                        .iter()
                        .map(move |&i| start.distance_squared(rest[i as usize].as_dvec3()))
                })
                .fold(f64::INFINITY, f64::min)
                .sqrt();
            warnings.push(Warning::StartsFarFromMesh {
                stage: k,
                controls: listed,
                count: far.len(),
                radius: def.radius(),
                nearest,
            });
        }
        // A falloff (or weights that blend) is smooth: no seam to warn of.
        let blends = match region {
            Region::Falloff { .. } => true,
            Region::Weights { weights, .. } => weights.iter().any(|&w| w < 1.0),
            _ => false,
        };
        if !all && !blends {
            let mut is_in = vec![false; rest.len()];
            for &i in selected.iter().chain(&joined) {
                is_in[i as usize] = true;
            }
            let outside: Vec<Vec3> = (0..rest.len())
                .filter(|&i| !is_in[i])
                .map(|i| rest[i])
                .collect();
            let (_, crossing) = reach(def, &outside);
            let cut: Vec<usize> = (0..crossing.len())
                .filter(|&j| crossing[j] && touched[j] && lengths[j] > tol)
                .collect();
            if !cut.is_empty() {
                warnings.push(Warning::SupportCrossesRegion {
                    stage: k,
                    controls: cut.iter().copied().take(LISTED).collect(),
                    count: cut.len(),
                });
            }
        }
    }
    if any_linear {
        let leaked: Vec<usize> = (0..rest.len())
            .filter(|&i| !near_any[i] && moves[i] > tol)
            .collect();
        if let Some(&worst) = leaked
            .iter()
            .max_by(|a, b| moves[**a].total_cmp(&moves[**b]))
        {
            warnings.push(Warning::PolynomialLeak {
                vertices: leaked.len(),
                largest: moves[worst],
                example: worst as u32,
            });
        }
    }
    let flipped = flipped_faces(
        rest,
        moved,
        triangles,
        &moves.iter().map(|&m| m > tol).collect::<Vec<bool>>(),
    );
    let folds = crate::folds::folds(rest, triangles, stages, combine, groups)?;
    if !folds.triangles.is_empty() {
        warnings.push(Warning::InsideOut {
            count: folds.triangles.len(),
            triangles: folds.triangles.iter().copied().take(LISTED).collect(),
            fold_phase: folds.fold_phase,
        });
    }
    // Creases: turned against their neighbours where the map does not fold.
    let creases: Vec<u32> = flipped
        .iter()
        .copied()
        .filter(|t| folds.triangles.binary_search(t).is_err())
        .collect();
    if !creases.is_empty() {
        let nearly_singular = warnings
            .iter()
            .any(|w| matches!(w, Warning::IllConditioned { .. }));
        warnings.push(Warning::FlippedFaces {
            count: creases.len(),
            triangles: creases.iter().copied().take(LISTED).collect(),
            nearly_singular,
        });
    }
    let stretch = crate::stretch::summary(rest, moved, triangles, options.stretch_limit);
    if !stretch.over.is_empty() {
        warnings.push(Warning::Stretched {
            count: stretch.over.len(),
            triangles: stretch.over.iter().copied().take(LISTED).collect(),
            largest: stretch.largest,
            limit: options.stretch_limit,
        });
    }
    Ok(Diagnostics {
        largest_stretch: stretch.largest,
        largest_stretch_face: stretch.face,
        stretched: stretch.over,
        stretch_limit: options.stretch_limit,
        self_intersections: None,
        moved: moved_count,
        largest_move: largest.map(|m| *m.1).unwrap_or(0.0),
        largest_move_vertex: largest.map(|m| m.0 as u32),
        flipped,
        inside_out: folds.triangles,
        fold_phase: folds.fold_phase,
        warnings,
    })
}

/// For each start, how many of `points` lie within `radius` of it (the
/// vertices a control vector can move).
pub fn vertices_within(points: &[Vec3], starts: &[DVec3], radius: f64) -> Vec<usize> {
    let tree = crate::octree::Octree::new(starts);
    points
        .par_chunks(16384)
        .map(|chunk| {
            let mut count = vec![0usize; starts.len()];
            for p in chunk {
                tree.for_each_within(p.as_dvec3(), radius, |j, _| count[j as usize] += 1);
            }
            count
        })
        .reduce(
            || vec![0usize; starts.len()],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x += y;
                }
                a
            },
        )
}

/// Each control's displacement less the mean of its neighbours' (the other
/// starts within R; none: zero), times the phase. One lone vector keeps its
/// length, the fold-free bound's case; starts moving together count little.
fn relative_moves(def: &Deformation, moves: &[DVec3], phase: f64) -> Vec<f64> {
    let starts = def.starts();
    let radius = def.radius();
    (0..starts.len())
        .into_par_iter()
        .with_min_len(64)
        .map(|j| {
            let (mut sum, mut n) = (DVec3::ZERO, 0usize);
            def.octree().for_each_within(starts[j], radius, |k, _| {
                if k as usize != j {
                    sum += moves[k as usize];
                    n += 1;
                }
            });
            let mean = if n > 0 { sum / n as f64 } else { DVec3::ZERO };
            (moves[j] - mean).length() * phase
        })
        .collect()
}

/// For each point, whether some start lies within R; for each start,
/// whether some point lies within R. Blocked like evaluation.
fn reach(def: &Deformation, points: &[Vec3]) -> (Vec<bool>, Vec<bool>) {
    reach_of(def.octree(), def.starts().len(), def.radius(), points)
}

/// The starts (`starts` of them, in `octree`) farther than `radius` from
/// every one of `points`: [`Deformation::starts_out_of_reach`] and
/// [`crate::System::starts_out_of_reach`].
pub(crate) fn out_of_reach<P: Point>(
    octree: &Octree,
    starts: usize,
    radius: f64,
    points: &[P],
) -> Vec<usize> {
    let (_, touched) = reach_of(octree, starts, radius, points);
    (0..starts).filter(|&j| !touched[j]).collect()
}

/// [`reach`] of any starts' octree.
fn reach_of<P: Point>(
    octree: &Octree,
    starts: usize,
    radius: f64,
    points: &[P],
) -> (Vec<bool>, Vec<bool>) {
    let touched: Vec<AtomicBool> = (0..starts).map(|_| AtomicBool::new(false)).collect();
    let mut near = vec![false; points.len()];
    if points.is_empty() || starts == 0 {
        return (near, vec![false; starts]);
    }
    let blocks = Blocks::for_starts(points, radius, starts);
    let mut out = vec![false; points.len()];
    for_each_cell(
        &blocks,
        &mut out,
        points.len() >= PARALLEL_POINTS,
        |(s, e), out, cand| {
            let cell = blocks.order[s..e]
                .iter()
                .map(|&i| points[i as usize].to_dvec3());
            cand.gather(octree, cell, radius);
            for (k, &i) in blocks.order[s..e].iter().enumerate() {
                let x: DVec3 = points[i as usize].to_dvec3();
                cand.for_each_weight(x, Kernel::C0, radius, |j, _| {
                    out[k] = true;
                    // A read first: a start hit by many points is written
                    // once, not once per point (no cache line ping-pong).
                    let t = &touched[j as usize];
                    if !t.load(AtomicOrdering::Relaxed) {
                        t.store(true, AtomicOrdering::Relaxed);
                    }
                });
            }
        },
    );
    for (k, &i) in blocks.order.iter().enumerate() {
        near[i as usize] = out[k];
    }
    (
        near,
        touched.into_iter().map(AtomicBool::into_inner).collect(),
    )
}

/// The cosine within which a face agrees with the faces around it at rest,
/// for [`flipped_faces`] to count it turned (60 degrees).
const CLEARLY_AGREED: f32 = 0.5;

/// Triangles whose deformed normal opposes the faces around them (the
/// area-weighted normals of the other faces at their corners) while at rest
/// it agreed with them within 60 degrees.
///
/// Only faces with a corner that moved can turn over; only the vertex
/// normals of their corners are needed (a local edit costs little).
fn flipped_faces(
    rest: &[Vec3],
    moved: &[Vec3],
    triangles: &[[u32; 3]],
    has_moved: &[bool],
) -> Vec<u32> {
    let n = rest.len();
    if triangles.is_empty() {
        return Vec::new();
    }
    let ok = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n);
    // Faces that may have turned over, and the vertices whose normals they need.
    let candidates: Vec<u32> = (0..triangles.len() as u32)
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&f| {
            let t = &triangles[f as usize];
            ok(t) && t.iter().any(|&i| has_moved[i as usize])
        })
        .collect();
    if candidates.is_empty() {
        return Vec::new();
    }
    let mut needed = vec![false; n];
    for &f in &candidates {
        for &i in &triangles[f as usize] {
            needed[i as usize] = true;
        }
    }
    let face = |p: &[Vec3], t: &[u32; 3]| -> Vec3 {
        let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
        (b - a).cross(c - a)
    };
    // Vertex normals of the needed vertices: the sum of the (area-weighted)
    // normals of the faces around them, at rest and deformed.
    let mut vr = vec![Vec3::ZERO; n];
    let mut vm = vec![Vec3::ZERO; n];
    for t in triangles {
        if ok(t) && t.iter().any(|&i| needed[i as usize]) {
            let (fr, fm) = (face(rest, t), face(moved, t));
            for &i in t {
                vr[i as usize] += fr;
                vm[i as usize] += fm;
            }
        }
    }
    candidates
        .into_par_iter()
        .with_min_len(4096)
        .filter(|&f| {
            let t = &triangles[f as usize];
            let [a, b, c] = t.map(|i| i as usize);
            // The faces around it: its corners' vertex normals without its
            // own share (a large face's own normal outweighed its
            // neighbours, so a face whose neighbours all turned away was
            // missed). At rest it must agree with them clearly (within
            // 60 degrees): a face already at a crease at rest (79 degrees
            // on the armadillo) tipped over by a small turn is not one the
            // deformation turned.
            let (own_r, own_m) = (face(rest, t), face(moved, t));
            let around_r = vr[a] + vr[b] + vr[c] - 3.0 * own_r;
            let around_m = vm[a] + vm[b] + vm[c] - 3.0 * own_m;
            let agreed = own_r.dot(around_r) >= CLEARLY_AGREED * own_r.length() * around_r.length();
            agreed && own_r.dot(around_r) > 0.0 && own_m.dot(around_m) < 0.0
        })
        .collect()
}

impl crate::System {
    /// The starts farther than R from every one of `points`, by index
    /// ([`Deformation::starts_out_of_reach`], before any solve).
    pub fn starts_out_of_reach<P: Point>(&self, points: &[P]) -> Vec<usize> {
        let s = &self.shared;
        out_of_reach(&s.octree, s.starts.len(), s.radius, points)
    }
}

impl Deformation {
    /// The starts farther than R from every one of `points`, by index: they
    /// move none of them (the diagnostics' `StartsFarFromMesh`, for a
    /// caller that checks before fitting or posing). f32 or f64 points,
    /// compared as they are.
    pub fn starts_out_of_reach<P: Point>(&self, points: &[P]) -> Vec<usize> {
        crate::diagnose::out_of_reach(&self.octree, self.starts.len(), self.radius, points)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_warning_numbers_as_the_file_or_as_an_editor() {
        // Controls 2 and 5 listed of `count` far from the mesh.
        let far = |count| Warning::StartsFarFromMesh {
            stage: 0,
            controls: vec![2, 5],
            count,
            radius: 0.5,
            nearest: 0.75,
        };
        let w = far(2);
        let file = w.to_string();
        assert!(
            file.starts_with("deformation 0: ") && file.ends_with("controls 2, 5"),
            "{file}"
        );
        assert_eq!(w.numbered(Numbering::File).to_string(), file);
        assert!(file.contains("(the nearest 0.75 away)"), "{file}");
        // More than listed: the distance is the listed ones', said so.
        let many = far(12).to_string();
        assert!(
            many.contains("(the nearest of those listed 0.75 away)")
                && many.ends_with("and 10 more"),
            "{many}"
        );
        let editor = w.numbered(Numbering::Editor).to_string();
        assert!(
            editor.starts_with("layer 0: ") && editor.ends_with("controls 2, 5"),
            "{editor}"
        );
        // Mesh indices are indices either way.
        let t = Warning::InsideOut {
            count: 1,
            triangles: vec![7],
            fold_phase: None,
        };
        assert_eq!(t.numbered(Numbering::Editor).to_string(), t.to_string());
    }

    use super::*;
    use crate::{Combine, FitOptions, FittedStage, compose, compose_diagnosed};

    /// A flat grid of n x n vertices in the XY plane, two triangles a square.
    fn grid(n: usize) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..n {
            for i in 0..n {
                p.push(Vec3::new(
                    i as f32 / (n - 1) as f32,
                    j as f32 / (n - 1) as f32,
                    0.0,
                ));
            }
        }
        let mut t = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
                t.push([a, b, d]);
                t.push([a, d, c]);
            }
        }
        (p, t)
    }

    /// Diagnoses both ways (after the fact, and while composing): they agree.
    fn run(stages: &[crate::FittedStage]) -> (Diagnostics, Vec<Vec3>) {
        let (rest, tris) = grid(41);
        let moved = compose(&rest, stages, Combine::Chain).expect("compose");
        let after =
            diagnose(&rest, &moved, &tris, stages, Combine::Chain, &|_| None).expect("diagnose");
        let (moved2, during) =
            compose_diagnosed(&rest, stages, Combine::Chain, &tris, &|_| None).expect("both");
        assert_eq!(moved, moved2);
        assert_eq!(after, during);
        (after, moved)
    }

    fn one(from: DVec3, to: DVec3, r: f64, poly: Polynomial) -> Deformation {
        Deformation::fit(&[from], &[to], FitOptions::new(r).with_polynomial(poly))
            .or_else(|_| {
                // Linear needs 4 starts: pin three far corners.
                let s = [
                    from,
                    DVec3::new(0.0, 0.0, 0.0),
                    DVec3::new(1.0, 0.0, 0.0),
                    DVec3::new(0.0, 1.0, 0.5),
                ];
                let t = [to, s[1], s[2], s[3]];
                Deformation::fit(&s, &t, FitOptions::new(r).with_polynomial(poly))
            })
            .expect("fit")
    }

    #[test]
    fn a_small_bump_is_clean() {
        let d = one(
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.5, 0.5, 0.05),
            0.2,
            Polynomial::None,
        );
        let (r, _) = run(&[FittedStage {
            deformation: d,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        assert!(r.moved > 0 && r.moved < 41 * 41 / 5);
        assert!((r.largest_move - 0.05).abs() < 1e-6);
    }

    /// A radius thousands of times the model (a user's R = 1e6 on a model
    /// 229 across) is said, with the figures in plain numbers; a well-posed
    /// edit of three starts is not warned of.
    #[test]
    fn a_nearly_singular_system_is_said() {
        let starts = [
            DVec3::new(0.3, 0.3, 0.0),
            DVec3::new(0.7, 0.4, 0.0),
            DVec3::new(0.5, 0.8, 0.0),
        ];
        let moves = [DVec3::Z * 0.05, DVec3::X * 0.05, DVec3::Y * -0.1];
        let targets: Vec<DVec3> = starts.iter().zip(&moves).map(|(s, m)| *s + *m).collect();
        for (radius, warned) in [(1e4, true), (0.3, false)] {
            let d = Deformation::fit(&starts, &targets, FitOptions::new(radius)).expect("fit");
            assert!((d.largest_move() - 0.1).abs() < 1e-12);
            let (r, _) = run(&[FittedStage {
                deformation: d,
                region: Region::All,
                phase: 1.0,
                sweep: None,
                rigid_part: false,
            }]);
            let said: Vec<String> = r
                .warnings
                .iter()
                .filter(|w| w.kind() == "ill_conditioned")
                .map(ToString::to_string)
                .collect();
            assert_eq!(
                said.len(),
                usize::from(warned),
                "R {radius}: {:?}",
                r.warnings
            );
            if warned {
                let m = &said[0];
                assert!(
                    m.starts_with("deformation 0: its coefficients reach "),
                    "{m}"
                );
                assert!(m.contains("(R = 10000 for a model 1.414 across)"), "{m}");
            }
        }
    }

    /// A crease's advice is a larger radius, unless a deformation is nearly
    /// singular: then a larger radius is the wrong way.
    #[test]
    fn a_crease_advises_by_the_system() {
        let said = |nearly_singular| {
            Warning::FlippedFaces {
                count: 2,
                triangles: vec![4, 9],
                nearly_singular,
            }
            .to_string()
        };
        assert!(said(false).ends_with("a sharp crease of the surface; a larger radius smooths it"));
        let singular = said(true);
        assert!(singular.contains("(triangles 4, 9)"), "{singular}");
        assert!(
            singular.ends_with("not a larger one") && !singular.contains("smooths"),
            "{singular}"
        );
    }

    #[test]
    fn a_sideways_shove_past_the_bound_folds_and_is_said() {
        // C2 bound: 0.474 R. A shove of 0.8 R along the surface folds it.
        let d = one(
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.66, 0.5, 0.0),
            0.2,
            Polynomial::None,
        );
        let (r, _) = run(&[FittedStage {
            deformation: d,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(
            r.warnings
                .iter()
                .any(|w| matches!(w, Warning::PastFoldFreeBound { .. }))
        );
        assert!(!r.flipped.is_empty(), "{:?}", r.warnings);
        // Half as far is within the bound: no fold.
        let d = one(
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.58, 0.5, 0.0),
            0.2,
            Polynomial::None,
        );
        let (r, _) = run(&[FittedStage {
            deformation: d,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(
            r.flipped.is_empty() && r.warnings.is_empty(),
            "{:?}",
            r.warnings
        );
    }

    #[test]
    fn far_starts_empty_regions_cut_supports_and_leaks_are_named() {
        let far = one(
            DVec3::new(5.0, 5.0, 5.0),
            DVec3::new(5.0, 5.0, 5.05),
            0.2,
            Polynomial::None,
        );
        let (r, _) = run(&[FittedStage {
            deformation: far.clone(),
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(
            matches!(
                r.warnings[..],
                [Warning::StartsFarFromMesh { count: 1, .. }]
            ),
            "{:?}",
            r.warnings
        );
        // How far: from (5, 5, 5) to the grid's corner (1, 1, 0), said.
        let Warning::StartsFarFromMesh { nearest, .. } = r.warnings[0] else {
            unreachable!("matched above")
        };
        assert!((nearest - 57f64.sqrt()).abs() < 1e-6, "{nearest}");
        assert!(
            r.warnings[0]
                .to_string()
                .contains("(the nearest 7.55 away)"),
            "{}",
            r.warnings[0]
        );
        let empty = Region::Sphere {
            center: DVec3::splat(9.0),
            radius: 0.1,
        };
        let (r, _) = run(&[FittedStage {
            deformation: far,
            region: empty,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(matches!(
            r.warnings[..],
            [Warning::EmptyRegion { stage: 0, .. }]
        ));
        let bump = one(
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.5, 0.5, 0.05),
            0.3,
            Polynomial::None,
        );
        let half = Region::Box {
            min: DVec3::new(0.0, 0.0, -1.0),
            max: DVec3::new(0.55, 1.0, 1.0),
        };
        let (r, _) = run(&[FittedStage {
            deformation: bump,
            region: half,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(
            matches!(
                r.warnings[..],
                [Warning::SupportCrossesRegion { count: 1, .. }]
            ),
            "{:?}",
            r.warnings
        );
        // A linear polynomial fitted to a lifted corner tilts the whole sheet.
        let lin = one(
            DVec3::new(0.9, 0.9, 0.0),
            DVec3::new(0.9, 0.9, 0.1),
            0.2,
            Polynomial::Linear,
        );
        let (r, _) = run(&[FittedStage {
            deformation: lin,
            region: Region::All,
            phase: 1.0,
            sweep: None,
            rigid_part: false,
        }]);
        assert!(
            r.warnings
                .iter()
                .any(|w| matches!(w, Warning::PolynomialLeak { .. })),
            "{:?}",
            r.warnings
        );
    }

    #[test]
    fn vertices_within_counts_like_brute_force() {
        let (rest, _) = grid(30);
        let starts = [
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::new(0.0, 0.0, 0.1),
            DVec3::splat(9.0),
        ];
        let got = vertices_within(&rest, &starts, 0.2);
        for (j, s) in starts.iter().enumerate() {
            let want = rest
                .iter()
                .filter(|p| p.as_dvec3().distance(*s) < 0.2)
                .count();
            assert_eq!(got[j], want);
        }
        assert_eq!(got[2], 0);
    }

    #[test]
    fn reach_agrees_with_brute_force() {
        let (rest, _) = grid(60);
        let starts: Vec<DVec3> = (0..70)
            .map(|k| {
                DVec3::new(
                    (k as f64 * 0.37).fract() * 1.4 - 0.2,
                    (k as f64 * 0.71).fract() * 1.4 - 0.2,
                    0.05,
                )
            })
            .collect();
        let d = Deformation::fit(
            &starts,
            &starts,
            FitOptions::new(0.08).with_polynomial(Polynomial::None),
        )
        .expect("fit");
        let (near, touched) = reach(&d, &rest);
        for (i, p) in rest.iter().enumerate() {
            let want = starts.iter().any(|s| s.distance(p.as_dvec3()) < 0.08);
            assert_eq!(near[i], want, "point {i}");
        }
        for (j, s) in starts.iter().enumerate() {
            let want = rest.iter().any(|p| s.distance(p.as_dvec3()) < 0.08);
            assert_eq!(touched[j], want, "start {j}");
        }
    }

    /// A large face whose small neighbours all turned over around it is
    /// counted (its own area outweighed theirs in the sum of its corners'
    /// vertex normals, so it was missed: the armadillo's triangle 12662),
    /// and a face that already stood at a crease at rest (80 degrees from
    /// its neighbours) and turns a little further is not.
    #[test]
    fn a_face_is_judged_against_the_faces_around_it() {
        let rest = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::new(2.0, -1.0, 0.0),
            Vec3::new(3.0, 3.0, 0.0),
            Vec3::new(-1.0, 2.0, 0.0),
        ];
        let tris = vec![[0, 1, 2], [1, 0, 3], [2, 1, 4], [0, 2, 5]];
        // The three outer corners folded over onto the big face.
        let mut moved = rest.clone();
        moved[0].z = 0.001;
        moved[3] = Vec3::new(2.0, 1.0, 0.01);
        moved[4] = Vec3::new(1.0, 1.0, 0.01);
        moved[5] = Vec3::new(1.0, 2.0, 0.01);
        let all = vec![true; rest.len()];
        let flipped = flipped_faces(&rest, &moved, &tris, &all);
        assert!(flipped.contains(&0), "{flipped:?}");
        // A face 80 degrees from its neighbours at rest (a sharp ridge),
        // turned 20 degrees further: a crease it had, not one made.
        let ridge = |deg: f32| {
            let (s, c) = deg.to_radians().sin_cos();
            // Face 0 tilted about the x axis; faces 1 and 2 flat beside it.
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.5, c, s),
                Vec3::new(0.5, -1.0, 0.0),
                Vec3::new(1.5, -0.5, 0.0),
            ]
        };
        let tris = vec![[0, 1, 2], [1, 0, 3], [1, 3, 4]];
        let (r, m) = (ridge(80.0), ridge(100.0));
        let turned = flipped_faces(&r, &m, &tris, &[true; 5]);
        assert!(turned.is_empty(), "{turned:?}");
        // The same turn from flat is counted.
        let (r, m) = (ridge(0.0), ridge(100.0));
        let turned = flipped_faces(&r, &m, &tris, &[true; 5]);
        assert!(turned.contains(&0), "{turned:?}");
    }
}
