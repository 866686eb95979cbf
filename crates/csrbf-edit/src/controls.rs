//! The JSON control file: one deformation, or `{"deformations": [...]}`
//! applied in order, each with an optional region and phase.
//!
//! ```json
//! {"kernel": "c2", "radius": 0.3, "polynomial": "linear",
//!  "controls": [{"from": [0, 0, 0], "to": [0, 0, 0.1]}]}
//! ```
//!
//! Every problem is reported with the JSON path of the value at fault
//! (`deformations[1].controls[3].from`) or, for syntax errors, the line and
//! column.

use glam::{DVec3, Vec3};
use serde_json::{Map, Value};

use csrbf::Combine;
use csrbf::FitOptions;
use csrbf::Ordering;
use csrbf::SolverChoice;
use csrbf::handle::{Handle, Rotation};
use csrbf::{Kernel, Polynomial};
use csrbf::{Origin, Region};
use csrbf::{Path, Paths, SweepOptions};

/// A problem in a control file, with where it is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{location}: {message}")]
pub struct ControlError {
    /// `line L, column C` for syntax errors, else the JSON path.
    pub location: String,
    /// What is wrong.
    pub message: String,
}

/// The most steps a handle's turn past the fold-free bound is swept in by
/// itself ([`ControlSpec::sweep_to_use`]).
pub const AUTO_SWEEP_STEPS: usize = 64;

/// One deformation as a control file describes it.
#[derive(Clone, Debug, PartialEq)]
pub struct ControlSpec {
    /// Start points.
    pub starts: Vec<DVec3>,
    /// Destinations.
    pub targets: Vec<DVec3>,
    /// Kernel, radius, polynomial, ordering, solver.
    pub options: FitOptions,
    /// Where it applies.
    pub region: Region,
    /// Phase of this deformation within a chain (default 1).
    pub phase: f64,
    /// A handle whose control vectors are added to `starts` and `targets`
    /// by [`ControlSpec::resolve`] (they depend on the mesh).
    pub handle: Option<Handle>,
    /// Where the handle's pins go.
    pub anchor: Option<Region>,
    /// A name for people (`"name"`; the studio's layer list shows it).
    pub name: Option<String>,
    /// A fold-free sweep (`"sweep": true` or `{"steps": k}`) instead of the
    /// papers' single map; None (the default) for the single map.
    pub sweep: Option<SweepOptions>,
    /// The paths the starts follow in a sweep: straight, except a handle's
    /// moving samples, which [`ControlSpec::resolve`] sets on its motion.
    pub paths: Paths,
    /// A resolved handle's rigid part: its own vertices, moved as one by
    /// the handle's motion exactly (a stage of its own before this
    /// deformation's, which then blends the rest of its region: the region
    /// without the handle's vertices and the anchor's, which stay still).
    pub rigid: Option<RigidPart>,
}

/// A handle's own vertices and the affine fit that moves them as one.
#[derive(Clone, Debug, PartialEq)]
pub struct RigidPart {
    /// The handle's vertices, ascending.
    pub vertices: Vec<u32>,
    /// The anchor's vertices (held still), ascending.
    pub held: Vec<u32>,
    /// Control vectors of the motion: the handle's samples and four points
    /// around them (so the affine part is determined), each moved by it.
    pub starts: Vec<DVec3>,
    /// Their destinations.
    pub targets: Vec<DVec3>,
    /// The motion as a path (a sweep follows the turn).
    pub path: Path,
}

impl RigidPart {
    /// The options of its fit: the deformation's, with the linear
    /// polynomial (which reproduces the motion exactly: every control moves
    /// by the same affine map, so the kernel part is zero).
    pub fn options(&self, of: FitOptions) -> FitOptions {
        of.with_polynomial(Polynomial::Linear)
    }

    /// Its sweep's paths: every control on the motion.
    pub fn paths(&self) -> Paths {
        Paths {
            moving: Some((0..self.starts.len(), self.path)),
        }
    }

    /// Its region: the handle's vertices at weight 1, and the anchor's at
    /// weight 0 (not moved: listed so that the checks know the blend after
    /// it meets them on purpose).
    pub fn region(&self) -> Region {
        let vertices = self.vertices.iter().chain(&self.held).copied().collect();
        let weights = (self.vertices.iter().map(|_| 1.0))
            .chain(self.held.iter().map(|_| 0.0))
            .collect();
        Region::Weights { vertices, weights }
    }

    /// Its pipeline stage, on its vertices, at `phase`, a sweep when
    /// `sweep` is.
    pub fn to_stage(
        &self,
        of: FitOptions,
        phase: f64,
        sweep: Option<SweepOptions>,
    ) -> csrbf::Stage {
        csrbf::Stage::new(self.starts.clone(), self.targets.clone(), self.options(of))
            .with_region(self.region())
            .with_phase(phase)
            .with_sweep(
                sweep,
                if sweep.is_some() {
                    self.paths()
                } else {
                    Paths::default()
                },
            )
            .as_rigid_part(true)
    }
}

/// What [`ControlSpec::resolve_cached`] keeps between resolutions on one
/// mesh: the surface's graph, and the last few connected regions with the
/// vertices they grew from.
#[derive(Default)]
pub struct SurfaceCache {
    surface: Option<csrbf::Surface>,
    regions: Vec<Resolved>,
    walks: usize,
}

/// A connected region, the vertices it grew from (with their distances),
/// and what it became on the surface.
struct Resolved {
    region: Region,
    seeds: Vec<(u32, f64)>,
    weights: Region,
}

impl SurfaceCache {
    /// How many regions are kept (one per layer of a studio document, say).
    const REGIONS: usize = 8;

    /// The surface of `points` and `triangles`, made on first use (or when
    /// the number of points changed: another mesh).
    fn surface(
        &mut self,
        points: &[Vec3],
        triangles: &[[u32; 3]],
    ) -> csrbf::Result<&csrbf::Surface> {
        if self
            .surface
            .as_ref()
            .is_none_or(|s| s.len() != points.len())
        {
            self.regions.clear();
            self.surface = Some(csrbf::Surface::new(points, triangles)?);
        }
        self.surface
            .as_ref()
            .ok_or_else(|| csrbf::RegionError::NeedsSurface.into())
    }

    /// `region` grown from `seeds` on the surface, or the same resolved
    /// before.
    fn region(&mut self, region: &Region, seeds: Vec<(u32, f64)>) -> csrbf::Result<Region> {
        if let Some(r) = self
            .regions
            .iter()
            .find(|r| r.region == *region && r.seeds == seeds)
        {
            return Ok(r.weights.clone());
        }
        let surface = self
            .surface
            .as_ref()
            .ok_or(csrbf::RegionError::NeedsSurface)?;
        let done = region.on_surface(surface, &seeds)?;
        self.walks += 1;
        if self.regions.len() == Self::REGIONS {
            self.regions.remove(0);
        }
        self.regions.push(Resolved {
            region: region.clone(),
            seeds,
            weights: done.clone(),
        });
        Ok(done)
    }

    /// How many regions were resolved by walking the surface (the others
    /// came from the cache).
    pub fn walks(&self) -> usize {
        self.walks
    }
}

impl ControlSpec {
    /// Whether the deformation depends on a mesh: a handle (its control
    /// vectors) or a connected region (its weights).
    pub fn needs_mesh(&self) -> bool {
        self.handle.is_some() || self.region.needs_surface()
    }

    /// [`ControlSpec::resolve_on`] without faces: a handle is sampled on
    /// `points`, but a connected region is refused
    /// ([`csrbf::RegionError::NeedsSurface`]).
    pub fn resolve(
        &self,
        points: &[Vec3],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> csrbf::Result<ControlSpec> {
        self.resolve_on(points, &[], groups)
    }

    /// The same deformation made concrete on a mesh (`points`, its
    /// `triangles`; `groups` resolves part names): its handle turned into
    /// control vectors (added after the file's own controls) and a
    /// connected region into the weights of the vertices it reaches along
    /// the surface ([`Region::Weights`], by [`Region::on_surface`]), from the
    /// handle's selection or from the moving starts. Without either, a copy.
    pub fn resolve_on(
        &self,
        points: &[Vec3],
        triangles: &[[u32; 3]],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
    ) -> csrbf::Result<ControlSpec> {
        self.resolve_cached(points, triangles, groups, &mut SurfaceCache::default())
    }

    /// [`ControlSpec::resolve_on`] on one mesh again and again (the
    /// studio's drag, where destinations move): `cache` keeps the surface's
    /// graph and the regions resolved lately, reused while a region and
    /// the vertices it grows from are the same (the graph and the walk
    /// along the surface are most of a resolution).
    pub fn resolve_cached(
        &self,
        points: &[Vec3],
        triangles: &[[u32; 3]],
        groups: &dyn Fn(&str) -> Option<Vec<u32>>,
        cache: &mut SurfaceCache,
    ) -> csrbf::Result<ControlSpec> {
        let mut out = self.clone();
        // The handle's vertices and the anchor's: moved as one, and held,
        // exactly (the rest of the region blends between them).
        let mut exclude: Vec<u32> = Vec::new();
        if let Some(h) = out.handle.take() {
            let anchor = out.anchor.take();
            let v = h.controls(
                points,
                anchor.as_ref(),
                self.options.radius,
                self.options.polynomial,
                groups,
            )?;
            let first = out.starts.len();
            let path = handle_path(&h, v.pivot);
            out.paths.moving = Some((first..first + v.moving, path));
            let mut rigid = rigid_part(&h, &v, self.options.radius, path, points, groups)?;
            if let Some(a) = &anchor {
                rigid.held = a.select(points, groups)?;
            }
            rigid.vertices.sort_unstable();
            exclude.extend(rigid.vertices.iter().chain(&rigid.held).copied());
            out.rigid = Some(rigid);
            out.starts.extend(v.starts);
            out.targets.extend(v.targets);
        }
        let Some(origin) = self.region.origin() else {
            out.region = without(&out.region, &exclude, points, groups)?;
            return Ok(out);
        };
        if triangles.is_empty() {
            return Err(csrbf::RegionError::NeedsSurface.into());
        }
        let surface = cache.surface(points, triangles)?;
        let seeds = match origin {
            Origin::Handle => {
                let h = self.handle.as_ref().ok_or_else(|| {
                    csrbf::Error::BadHandle(
                        "the region is connected to the handle's selection, but there is no handle"
                            .into(),
                    )
                })?;
                h.select
                    .select(points, groups)?
                    .into_iter()
                    .map(|v| (v, 0.0))
                    .collect()
            }
            // Pins (and a handle's anchor samples) do not move: not a source.
            Origin::Starts => {
                let moving: Vec<DVec3> = out
                    .starts
                    .iter()
                    .zip(&out.targets)
                    .filter(|(s, t)| s != t)
                    .map(|(s, _)| *s)
                    .collect();
                surface.seeds_at(&moving)
            }
            other => {
                return Err(csrbf::Error::BadHandle(format!(
                    "a connected region measured from {other:?}, which this version cannot resolve"
                )));
            }
        };
        out.region = cache.region(&self.region, seeds)?;
        out.region = without(&out.region, &exclude, points, groups)?;
        Ok(out)
    }

    /// Fits the deformation (a handle must be resolved first): one stage,
    /// or a sweep's steps, on its region at its phase ([`crate::fit_spec`]
    /// with the fit's figures).
    pub fn fit(&self) -> csrbf::Result<Vec<csrbf::FittedStage>> {
        Ok(crate::fit_spec(self)?.stages)
    }
}

/// A handle's rigid part: its vertices, and the control vectors of its
/// motion (the samples the handle made and four points around them at R/2,
/// all moved by the motion).
fn rigid_part(
    h: &Handle,
    v: &csrbf::HandleControls,
    radius: f64,
    path: Path,
    points: &[Vec3],
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> csrbf::Result<RigidPart> {
    let vertices = h.select.select(points, groups)?;
    let motion = h.motion(v.pivot);
    let mut starts: Vec<DVec3> = v.starts[..v.moving].to_vec();
    let centre = starts.iter().copied().sum::<DVec3>() / starts.len().max(1) as f64;
    // A tetrahedron's corners (turned off the axes, so they meet no grid
    // of samples), so four points not in one plane determine the affine
    // part even for a flat selection.
    let r = 0.5137 * radius;
    for c in [
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(1.0, -1.0, -1.0),
        DVec3::new(-1.0, 1.0, -1.0),
        DVec3::new(-1.0, -1.0, 1.0),
    ] {
        let p = centre + c.normalize() * r;
        if starts
            .iter()
            .all(|s| s.distance(p) > radius * csrbf::handle::MIN_SAMPLE_SPACING)
        {
            starts.push(p);
        }
    }
    let targets = starts.iter().map(|&p| motion.transform_point3(p)).collect();
    Ok(RigidPart {
        vertices,
        held: Vec::new(),
        starts,
        targets,
        path,
    })
}

/// `region` without the points `exclude` lists (a handle's and its
/// anchor's, which the rigid part moves and the anchor holds): as weights,
/// the same elsewhere.
fn without(
    region: &Region,
    exclude: &[u32],
    points: &[Vec3],
    groups: &dyn Fn(&str) -> Option<Vec<u32>>,
) -> csrbf::Result<Region> {
    if exclude.is_empty() {
        return Ok(region.clone());
    }
    let mut out = vec![false; points.len()];
    for &i in exclude {
        if let Some(o) = out.get_mut(i as usize) {
            *o = true;
        }
    }
    let (active, weights) = region.weights(points, groups)?;
    let (vertices, weights) = active
        .into_iter()
        .zip(weights)
        .filter(|(i, _)| !out[*i as usize])
        .unzip();
    Ok(Region::Weights { vertices, weights })
}

/// A handle's motion as the path of its moving samples: the scale, turn
/// and translation spread over the phase, about the pivot the samples were
/// placed with.
fn handle_path(h: &Handle, pivot: DVec3) -> Path {
    let pivot = h.rotate.and_then(|r| r.pivot).unwrap_or(pivot);
    let (axis, angle) = h.rotate.map_or((DVec3::ZERO, 0.0), |r| {
        (r.axis.normalize_or_zero(), r.angle_deg.to_radians())
    });
    Path::Motion {
        pivot,
        axis,
        angle,
        scale: h.scale.unwrap_or(1.0),
        translate: h.translate.unwrap_or(DVec3::ZERO),
    }
}

/// A parsed control file: its deformations and warnings about keys it did
/// not know (kept for the caller to print).
#[derive(Clone, Debug, PartialEq)]
pub struct ControlFile {
    /// The deformations, in order.
    pub deformations: Vec<ControlSpec>,
    /// How they act together (`"combine"`, default chain).
    pub combine: Combine,
    /// Keys that were ignored, with their paths.
    pub warnings: Vec<String>,
}

impl ControlSpec {
    /// The pipeline stage of this deformation (a sweep's too). A handle
    /// must be resolved on the mesh first ([`ControlSpec::resolve`]).
    pub fn to_stage(&self) -> csrbf::Result<csrbf::Stage> {
        if self.handle.is_some() {
            return Err(csrbf::Error::BadHandle(
                "not resolved yet: call ControlSpec::resolve with the mesh first".into(),
            ));
        }
        Ok(
            csrbf::Stage::new(self.starts.clone(), self.targets.clone(), self.options)
                .with_region(self.region.clone())
                .with_phase(self.phase)
                .with_sweep(self.sweep, self.paths.clone()),
        )
    }

    /// The pipeline stages of this deformation: a resolved handle's rigid
    /// part first, then the deformation's own stage (both a sweep when
    /// [`ControlSpec::sweep_to_use`] says so).
    pub fn to_stages(&self) -> csrbf::Result<Vec<csrbf::Stage>> {
        let Some(r) = &self.rigid else {
            return Ok(vec![self.to_stage()?]);
        };
        let sweep = self.sweep_to_use();
        let own = ControlSpec {
            sweep,
            ..self.clone()
        }
        .to_stage()?;
        Ok(vec![r.to_stage(self.options, self.phase, sweep), own])
    }

    /// The sweep this deformation is taken as: its own, or for a resolved
    /// handle whose turn passes the fold-free bound (some control moved
    /// farther from a neighbour's move, a start within R, than the kernel
    /// allows: where the single map may fold, as the report judges it) a
    /// sweep along the turn, by itself, of as many steps as bring each
    /// step's moves within the bound (and one per 10 degrees of turn, so
    /// the arc is followed), at most [`AUTO_SWEEP_STEPS`]: the papers' bound
    /// step by step, not the certificate's search (seconds on a drag).
    pub fn sweep_to_use(&self) -> Option<SweepOptions> {
        if self.sweep.is_some() || self.rigid.is_none() {
            return self.sweep;
        }
        let r = self.options.radius;
        let bound = self.options.kernel.fold_free_ratio() * r;
        let moves: Vec<DVec3> = (self.starts.iter().zip(&self.targets))
            .map(|(s, t)| *t - *s)
            .collect();
        let mut worst = 0.0f64;
        for (i, a) in self.starts.iter().enumerate() {
            for (j, b) in self.starts.iter().enumerate().skip(i + 1) {
                if a.distance_squared(*b) < r * r {
                    worst = worst.max(moves[i].distance(moves[j]));
                }
            }
        }
        if !(worst > bound) {
            return None;
        }
        let turn = match self.rigid.as_ref().map(|p| p.path) {
            Some(Path::Motion { axis, angle, .. }) if axis != DVec3::ZERO => {
                angle.abs().to_degrees()
            }
            _ => 0.0,
        };
        let steps = ((worst / bound).ceil() as usize)
            .max((turn / 10.0).ceil() as usize)
            .clamp(2, AUTO_SWEEP_STEPS);
        Some(SweepOptions::default().with_steps(Some(steps)))
    }

    /// A deformation of these control vectors over the whole mesh at full phase.
    pub fn new(starts: Vec<DVec3>, targets: Vec<DVec3>, options: FitOptions) -> ControlSpec {
        ControlSpec {
            starts,
            targets,
            options,
            region: Region::All,
            phase: 1.0,
            handle: None,
            anchor: None,
            name: None,
            sweep: None,
            paths: Paths::default(),
            rigid: None,
        }
    }

    /// The deformation as a control file's JSON object (what
    /// [`ControlFile::parse`] reads back to the same value); defaults are
    /// written too, so a file says what it means.
    pub fn to_json(&self) -> Value {
        let o = &self.options;
        let mut v = serde_json::json!({});
        if let Some(n) = &self.name {
            v["name"] = n.as_str().into();
        }
        let fields = serde_json::json!({
            "kernel": o.kernel.name(),
            "radius": o.radius,
            "polynomial": o.polynomial.name(),
        });
        if let (Value::Object(v), Value::Object(f)) = (&mut v, fields) {
            v.extend(f);
        }
        if o.solver != SolverChoice::Auto {
            v["solver"] = o.solver.name().into();
        }
        if o.ordering != Ordering::Auto {
            v["ordering"] = o.ordering.name().into();
        }
        if self.phase != 1.0 {
            v["phase"] = self.phase.into();
        }
        if self.region != Region::All {
            v["region"] = region_json(&self.region);
        }
        if !self.starts.is_empty() || self.handle.is_none() {
            v["controls"] = self
                .starts
                .iter()
                .zip(&self.targets)
                .map(|(s, t)| serde_json::json!({ "from": s.to_array(), "to": t.to_array() }))
                .collect();
        }
        if let Some(h) = &self.handle {
            let mut hj = serde_json::json!({ "select": region_json(&h.select) });
            if let Some(r) = &h.rotate {
                hj["rotate"] =
                    serde_json::json!({ "axis": r.axis.to_array(), "angle_deg": r.angle_deg });
                if let Some(p) = r.pivot {
                    hj["rotate"]["pivot"] = p.to_array().into();
                }
            }
            if let Some(s) = h.scale {
                hj["scale"] = s.into();
            }
            if let Some(t) = h.translate {
                hj["translate"] = t.to_array().into();
            }
            if let Some(n) = h.samples {
                hj["samples"] = n.into();
            }
            v["handle"] = hj;
        }
        if let Some(a) = &self.anchor {
            v["anchor"] = region_json(a);
        }
        match self.sweep {
            None => {}
            Some(o) => match o.steps {
                None => v["sweep"] = true.into(),
                Some(k) => v["sweep"] = serde_json::json!({ "steps": k }),
            },
        }
        v
    }
}

/// A region as a control file writes it.
pub fn region_json(r: &Region) -> Value {
    use serde_json::json;
    match r {
        Region::All => Value::Null,
        Region::Sphere { center, radius } => {
            json!({ "sphere": { "center": center.to_array(), "radius": radius } })
        }
        Region::Box { min, max } => {
            json!({ "box": { "min": min.to_array(), "max": max.to_array() } })
        }
        Region::Vertices(v) => json!({ "vertices": v }),
        Region::Group(name) => json!({ "group": name }),
        Region::Falloff { inner, width } => {
            let mut v = region_json(inner);
            v["falloff"] = (*width).into();
            v
        }
        Region::Connected { distance, from } => {
            json!({ "connected": { "distance": distance, "from": from.name() } })
        }
        Region::Weights { vertices, weights } => {
            json!({ "weights": { "vertices": vertices, "weights": weights } })
        }
        // A kind this writer does not know is written so that the reader
        // refuses it, naming it, rather than lost.
        other => json!({ "unknown region": other.to_string() }),
    }
}

impl From<&csrbf::Stage> for ControlSpec {
    /// The control-file form of a pipeline stage (for saving what a
    /// pipeline holds).
    fn from(s: &csrbf::Stage) -> ControlSpec {
        let mut spec = ControlSpec::new(s.starts.clone(), s.targets.clone(), s.options);
        spec.region = s.region.clone();
        spec.phase = s.phase;
        spec.sweep = s.sweep;
        spec.paths = s.paths.clone();
        spec
    }
}

impl ControlFile {
    /// A file of these deformations, combined this way.
    pub fn new(deformations: Vec<ControlSpec>, combine: Combine) -> ControlFile {
        ControlFile {
            deformations,
            combine,
            warnings: Vec::new(),
        }
    }

    /// The file as JSON: one deformation's object, or `{"combine": ..,
    /// "deformations": [..]}` for several. The one writer of control files
    /// (the studio's saves, the demos, `bench --export`).
    pub fn to_json(&self) -> Value {
        match &self.deformations[..] {
            [one] if self.combine == Combine::Chain => one.to_json(),
            list => serde_json::json!({
                "combine": self.combine.name(),
                "deformations": list.iter().map(ControlSpec::to_json).collect::<Vec<_>>(),
            }),
        }
    }

    /// [`ControlFile::to_json`], pretty-printed.
    pub fn to_text(&self) -> String {
        serde_json::to_string_pretty(&self.to_json()).unwrap_or_default()
    }

    /// Parses and checks a control file.
    pub fn parse(text: &str) -> Result<ControlFile, ControlError> {
        let text = crate::json::strip_bom(text);
        let root: Value = serde_json::from_str(text).map_err(|e| ControlError {
            location: format!("line {}, column {}", e.line(), e.column()),
            message: format!("invalid JSON: {}", crate::json::message_without_place(&e)),
        })?;
        crate::json::check_duplicate_keys(text).map_err(|e| ControlError {
            location: format!("line {}", e.second_line),
            message: e.to_string(),
        })?;
        ControlFile::from_value(&root)
    }

    /// A control file already parsed as JSON (a front end's own structure:
    /// Python's dict), read as [`ControlFile::parse`] reads a file's text.
    pub fn from_value(root: &Value) -> Result<ControlFile, ControlError> {
        let mut warnings = Vec::new();
        let obj = root
            .as_object()
            .ok_or_else(|| err("(top level)", "expected a JSON object"))?;
        let combine = match obj.get("combine") {
            None | Some(Value::Null) => Combine::default(),
            Some(Value::String(c)) => c
                .parse::<Combine>()
                .map_err(|e| err("combine", e.to_string()))?,
            Some(other) => {
                return Err(err(
                    "combine",
                    format!("expected \"chain\" or \"add\", found {other}"),
                ));
            }
        };
        let deformations = if let Some(list) = obj.get("deformations") {
            unknown_keys(
                obj,
                &["deformations", "combine", "comment"],
                "",
                &mut warnings,
            );
            let list = list
                .as_array()
                .ok_or_else(|| err("deformations", "expected a list of deformations"))?;
            if list.is_empty() {
                return Err(err(
                    "deformations",
                    "the list is empty: give at least one deformation",
                ));
            }
            list.iter()
                .enumerate()
                .map(|(i, d)| spec(d, &format!("deformations[{i}]"), &mut warnings))
                .collect::<Result<Vec<_>, _>>()?
        } else {
            vec![spec(root, "", &mut warnings)?]
        };
        if combine == Combine::Add
            && let Some(i) = deformations.iter().position(|d| d.sweep.is_some())
        {
            return Err(err(
                &format!("deformations[{i}].sweep"),
                "a sweep's steps act one after another; \"combine\": \"add\" cannot hold one: use \"chain\"",
            ));
        }
        Ok(ControlFile {
            deformations,
            combine,
            warnings,
        })
    }
}

const KEYS: &[&str] = &[
    "kernel",
    "radius",
    "polynomial",
    "controls",
    "region",
    "phase",
    "solver",
    "ordering",
    "name",
    "comment",
    "handle",
    "anchor",
    "combine",
    "sweep",
];

fn join(base: &str, key: &str) -> String {
    if base.is_empty() {
        key.to_owned()
    } else {
        format!("{base}.{key}")
    }
}

pub(crate) fn err(location: &str, message: impl Into<String>) -> ControlError {
    ControlError {
        location: location.to_owned(),
        message: message.into(),
    }
}

/// How a warning of [`ControlFile::warnings`] about a key the reader does
/// not know ends (`"handle.rotat: unknown key ignored"`): a file is read
/// with it, a front end building a file refuses it.
pub const UNKNOWN_KEY: &str = "unknown key ignored";

pub(crate) fn unknown_keys(
    obj: &Map<String, Value>,
    known: &[&str],
    base: &str,
    warnings: &mut Vec<String>,
) {
    for k in obj.keys().filter(|k| !known.contains(&k.as_str())) {
        match nearest_known(k, known) {
            Some(near) => warnings.push(format!(
                "{} (did you mean \"{near}\"?): {UNKNOWN_KEY}",
                join(base, k)
            )),
            None => warnings.push(format!("{}: {UNKNOWN_KEY}", join(base, k))),
        }
    }
}

/// The known key `key` is most likely a misspelling of (at most two letters
/// changed, added, dropped or swapped), if any.
fn nearest_known<'a>(key: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| (edit_distance(key, k), *k))
        .filter(|&(d, k)| d <= 2 && d < k.len())
        .min_by_key(|&(d, _)| d)
        .map(|(_, k)| k)
}

/// Letters changed, added, dropped or swapped (two side by side) to turn
/// `a` into `b` (the optimal string alignment distance).
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, x) in d[0].iter_mut().enumerate() {
        *x = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = best;
        }
    }
    d[a.len()][b.len()]
}

/// A key that is missing, said with the misspelling the object may hold
/// instead (`radius: missing (the file has "raduis")`).
fn missing(
    obj: &Map<String, Value>,
    at: &str,
    key: &str,
    known: &[&str],
    says: &str,
) -> ControlError {
    let typo = obj
        .keys()
        .filter(|k| !known.contains(&k.as_str()))
        .find(|k| nearest_known(k, known) == Some(key));
    match typo {
        Some(t) => err(
            at,
            format!("missing (the file has \"{t}\": a misspelling?): {says}"),
        ),
        None => err(at, format!("missing: {says}")),
    }
}

fn spec(v: &Value, base: &str, warnings: &mut Vec<String>) -> Result<ControlSpec, ControlError> {
    let at = |k: &str| join(base, k);
    let obj = v.as_object().ok_or_else(|| {
        err(
            if base.is_empty() { "(top level)" } else { base },
            "expected an object",
        )
    })?;
    unknown_keys(obj, KEYS, base, warnings);
    let name = |k: &str| -> Result<Option<&str>, ControlError> {
        match obj.get(k) {
            None | Some(Value::Null) => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.as_str())),
            Some(_) => Err(err(&at(k), "expected a string")),
        }
    };
    let kernel = match name("kernel")? {
        None => Kernel::C2,
        Some(s) => s
            .parse::<Kernel>()
            .map_err(|e| err(&at("kernel"), e.to_string()))?,
    };
    let polynomial = match name("polynomial")? {
        None => Polynomial::default(),
        Some(s) => s
            .parse::<Polynomial>()
            .map_err(|e| err(&at("polynomial"), e.to_string()))?,
    };
    let solver = match name("solver")? {
        None => SolverChoice::Auto,
        Some(s) => s
            .parse::<SolverChoice>()
            .map_err(|e| err(&at("solver"), e.to_string()))?,
    };
    let ordering = match name("ordering")? {
        None => Ordering::Auto,
        Some(s) => s
            .parse::<Ordering>()
            .map_err(|e| err(&at("ordering"), e.to_string()))?,
    };
    let radius = match obj.get("radius") {
        None => {
            return Err(missing(
                obj,
                &at("radius"),
                "radius",
                KEYS,
                "give the radius of support in the mesh's units",
            ));
        }
        Some(r) => r
            .as_f64()
            .ok_or_else(|| err(&at("radius"), format!("expected a number, found {r}")))?,
    };
    if !(radius > 0.0 && radius.is_finite()) {
        return Err(err(
            &at("radius"),
            format!("must be a finite number > 0, got {radius}"),
        ));
    }
    let phase = match obj.get("phase") {
        None => 1.0,
        Some(p) => p
            .as_f64()
            .filter(|p| (0.0..=1.0).contains(p))
            .ok_or_else(|| {
                err(
                    &at("phase"),
                    format!("must be a number within [0, 1], got {p}"),
                )
            })?,
    };
    let handle = match obj.get("handle") {
        None | Some(Value::Null) => None,
        Some(h) => Some(parse_handle(h, &at("handle"), warnings)?),
    };
    let anchor = match obj.get("anchor") {
        None | Some(Value::Null) => None,
        Some(_) if handle.is_none() => {
            return Err(err(
                &at("anchor"),
                "an anchor needs a handle: give \"handle\" too",
            ));
        }
        Some(r) => Some(not_connected(
            parse_region(r, &at("anchor"))?,
            &at("anchor"),
        )?),
    };
    let (starts, targets) = match obj.get("controls") {
        None if handle.is_some() => (Vec::new(), Vec::new()),
        None => {
            return Err(missing(
                obj,
                &at("controls"),
                "controls",
                KEYS,
                "give a list of {\"from\": [x, y, z], \"to\": [x, y, z]} or a \"handle\"",
            ));
        }
        Some(list) => vectors(list, &at("controls"), handle.is_some(), warnings)?,
    };
    let region = match obj.get("region") {
        None | Some(Value::Null) => Region::All,
        Some(r) => {
            // Measured from the handle when there is one, unless told.
            let origin = if handle.is_some() {
                Origin::Handle
            } else {
                Origin::Starts
            };
            parse_region_from(r, &at("region"), origin)?
        }
    };
    if region.origin() == Some(Origin::Handle) && handle.is_none() {
        return Err(err(
            &at("region.connected.from"),
            "\"handle\" measures from the handle's selection, but this deformation has no \"handle\": give one, or \"from\": \"starts\"",
        ));
    }
    let options = FitOptions::new(radius)
        .with_kernel(kernel)
        .with_polynomial(polynomial)
        .with_solver(solver)
        .with_ordering(ordering);
    let name = match obj.get("name") {
        None | Some(Value::Null) => None,
        Some(Value::String(n)) => Some(n.clone()),
        Some(other) => {
            return Err(err(
                &at("name"),
                format!("expected a string, found {other}"),
            ));
        }
    };
    let sweep = parse_sweep(obj.get("sweep"), &at("sweep"), warnings)?;
    Ok(ControlSpec {
        starts,
        targets,
        options,
        region,
        phase,
        handle,
        anchor,
        name,
        sweep,
        paths: Paths::default(),
        rigid: None,
    })
}

/// `"sweep"`: false or absent (the single map), true (k chosen), or
/// `{"steps": k}`.
fn parse_sweep(
    v: Option<&Value>,
    at: &str,
    warnings: &mut Vec<String>,
) -> Result<Option<SweepOptions>, ControlError> {
    match v {
        None | Some(Value::Null) | Some(Value::Bool(false)) => Ok(None),
        Some(Value::Bool(true)) => Ok(Some(SweepOptions::default())),
        Some(Value::Object(o)) => {
            unknown_keys(o, &["steps"], at, warnings);
            let steps = match o.get("steps") {
                None | Some(Value::Null) => None,
                Some(k) => Some(
                    k.as_u64()
                        .filter(|&k| k >= 1 && k as usize <= csrbf::MAX_STEPS)
                        .ok_or_else(|| {
                            err(
                                &join(at, "steps"),
                                format!(
                                    "must be a whole number from 1 to {}, got {k}",
                                    csrbf::MAX_STEPS
                                ),
                            )
                        })? as usize,
                ),
            };
            Ok(Some(SweepOptions::default().with_steps(steps)))
        }
        Some(other) => Err(err(
            at,
            format!("expected true, false or {{\"steps\": k}}, found {other}"),
        )),
    }
}

fn vectors(
    list: &Value,
    here: &str,
    may_be_empty: bool,
    warnings: &mut Vec<String>,
) -> Result<(Vec<DVec3>, Vec<DVec3>), ControlError> {
    let list = list
        .as_array()
        .ok_or_else(|| err(here, "expected a list of control vectors"))?;
    if list.is_empty() && !may_be_empty {
        // Work in progress (an editor saves a layer before its first
        // vector): read, does nothing, and said.
        warnings.push(format!(
            "{here}: no control vectors yet: this deformation moves nothing until one is added"
        ));
    }
    let mut starts = Vec::with_capacity(list.len());
    let mut targets = Vec::with_capacity(list.len());
    for (i, c) in list.iter().enumerate() {
        let here = format!("{here}[{i}]");
        let c = c
            .as_object()
            .ok_or_else(|| err(&here, "expected {\"from\": [x, y, z], \"to\": [x, y, z]}"))?;
        unknown_keys(c, &["from", "to", "name"], &here, warnings);
        starts.push(point(c.get("from"), &format!("{here}.from"))?);
        targets.push(point(c.get("to"), &format!("{here}.to"))?);
    }
    Ok((starts, targets))
}

pub(crate) fn number(v: Option<&Value>, at: &str) -> Result<Option<f64>, ControlError> {
    match v {
        None | Some(Value::Null) => Ok(None),
        Some(x) => x
            .as_f64()
            .filter(|x| x.is_finite())
            .map(Some)
            .ok_or_else(|| err(at, format!("expected a finite number, found {x}"))),
    }
}

/// `{"select": <region>, "rotate": {"axis": [..], "angle_deg": a, "pivot": [..]},
/// "scale": s, "translate": [..], "samples": n}`.
fn parse_handle(v: &Value, at: &str, warnings: &mut Vec<String>) -> Result<Handle, ControlError> {
    let obj = v.as_object().ok_or_else(|| {
        err(at, "expected {\"select\": <region>, \"rotate\": {...}, \"scale\": s, \"translate\": [x, y, z]}")
    })?;
    unknown_keys(
        obj,
        &[
            "select",
            "rotate",
            "scale",
            "translate",
            "samples",
            "comment",
        ],
        at,
        warnings,
    );
    let here = |k: &str| format!("{at}.{k}");
    let select = not_connected(
        parse_region(
            obj.get("select")
                .ok_or_else(|| err(&here("select"), "missing: give the region that moves"))?,
            &here("select"),
        )?,
        &here("select"),
    )?;
    let mut h = rigid_motion(obj, at, warnings, Handle::new(select))?;
    if let Some(n) = obj.get("samples").filter(|n| !n.is_null()) {
        let n = n
            .as_u64()
            .filter(|&n| (1..=100_000).contains(&n))
            .ok_or_else(|| {
                err(
                    &here("samples"),
                    format!("expected a whole number within 1..100000, found {n}"),
                )
            })?;
        h = h.with_samples(n as usize);
    }
    if h.rotate.is_none() && h.scale.is_none() && h.translate.is_none() {
        return Err(err(
            at,
            "the handle does not move: give rotate, scale or translate",
        ));
    }
    Ok(h)
}

/// A rigid motion's `rotate` (`{"axis": [..], "angle_deg": a, "pivot":
/// [..]}`), `scale` and `translate` of `obj` (at `at`), each optional, given
/// to `h`: a handle's, and a volume zone's that moves rigidly.
pub(crate) fn rigid_motion(
    obj: &serde_json::Map<String, Value>,
    at: &str,
    warnings: &mut Vec<String>,
    mut h: Handle,
) -> Result<Handle, ControlError> {
    let here = |k: &str| format!("{at}.{k}");
    if let Some(r) = obj.get("rotate").filter(|r| !r.is_null()) {
        let ro = r.as_object().ok_or_else(|| {
            err(
                &here("rotate"),
                "expected {\"axis\": [x, y, z], \"angle_deg\": a, \"pivot\": [x, y, z]}",
            )
        })?;
        let rat = here("rotate");
        unknown_keys(ro, &["axis", "angle_deg", "pivot"], &rat, warnings);
        let axis = point(ro.get("axis"), &format!("{rat}.axis"))?;
        if !(axis.length() > 0.0) {
            return Err(err(&format!("{rat}.axis"), "the axis must not be zero"));
        }
        let angle = number(ro.get("angle_deg"), &format!("{rat}.angle_deg"))?
            .ok_or_else(|| err(&format!("{rat}.angle_deg"), "missing: the angle in degrees"))?;
        let mut rot = Rotation::new(axis, angle);
        if ro.get("pivot").is_some_and(|p| !p.is_null()) {
            rot = rot.with_pivot(point(ro.get("pivot"), &format!("{rat}.pivot"))?);
        }
        h = h.with_rotation(rot);
    }
    if let Some(s) = number(obj.get("scale"), &here("scale"))? {
        if !(s > 0.0) {
            return Err(err(&here("scale"), format!("must be > 0, got {s}")));
        }
        h = h.with_scale(s);
    }
    if obj.get("translate").is_some_and(|t| !t.is_null()) {
        h = h.with_translation(point(obj.get("translate"), &here("translate"))?);
    }
    Ok(h)
}

pub(crate) fn point(v: Option<&Value>, at: &str) -> Result<DVec3, ControlError> {
    let v = v.ok_or_else(|| err(at, "missing: expected three numbers [x, y, z]"))?;
    let a = v
        .as_array()
        .filter(|a| a.len() == 3)
        .ok_or_else(|| err(at, format!("expected three numbers [x, y, z], found {v}")))?;
    let mut p = [0.0; 3];
    for (k, x) in a.iter().enumerate() {
        p[k] = x.as_f64().ok_or_else(|| {
            err(
                &format!("{at}[{k}]"),
                format!("expected a number, found {x}"),
            )
        })?;
        if !p[k].is_finite() {
            return Err(err(&format!("{at}[{k}]"), "not a finite number"));
        }
        if p[k].abs() > f32::MAX as f64 {
            return Err(err(
                &format!("{at}[{k}]"),
                format!(
                    "{} is beyond the range of 32-bit floats (about ±3.4e38) that meshes are kept in",
                    p[k]
                ),
            ));
        }
    }
    Ok(DVec3::from_array(p))
}

/// Refuses a connected region where only a deformation's own region may be
/// one (a handle's selection, an anchor).
fn not_connected(r: Region, at: &str) -> Result<Region, ControlError> {
    if r.needs_surface() {
        return Err(err(
            &join(at, "connected"),
            "a connected region is measured from a deformation's starts or handle: it can only be a deformation's \"region\"",
        ));
    }
    Ok(r)
}

/// A region as written in a control file (`{"sphere": ...}`, `{"box": ...}`,
/// `{"vertices": [...]}`, `{"group": name}`, `{"connected": {"distance":
/// d, "from": "starts" | "handle"}}` or `{"weights": {"vertices": [...],
/// "weights": [...]}}`); `at` is its JSON path, for errors. A connected
/// region without `"from"` measures from the starts.
///
/// A `"falloff": width` beside the kind blends the region's edge smoothly
/// over that width instead of cutting it (not wider than the region; along
/// the surface for a connected region).
pub fn parse_region(v: &Value, at: &str) -> Result<Region, ControlError> {
    parse_region_from(v, at, Origin::Starts)
}

/// [`parse_region`], a connected region without `"from"` measuring from `origin`.
fn parse_region_from(v: &Value, at: &str, origin: Origin) -> Result<Region, ControlError> {
    let Some(width) = v.as_object().and_then(|o| o.get("falloff")) else {
        return parse_plain_region(v, at, origin);
    };
    let here = format!("{at}.falloff");
    let width = width
        .as_f64()
        .filter(|w| *w > 0.0 && w.is_finite())
        .ok_or_else(|| err(&here, format!("expected a width > 0, found {width}")))?;
    let mut plain = v.as_object().cloned().unwrap_or_default();
    plain.remove("falloff");
    let inner = parse_plain_region(&Value::Object(plain), at, origin)?;
    if matches!(inner, Region::Weights { .. }) {
        return Err(err(&here, "weights blend as they are: give no falloff"));
    }
    if let Some(size) = inner.size()
        && width > size
    {
        return Err(err(
            &here,
            format!(
                "{width} is wider than the region itself ({size} across): the blend would reach farther than the region it softens"
            ),
        ));
    }
    if inner == Region::All {
        return Err(err(&here, "everything has no edge to blend"));
    }
    Ok(Region::Falloff {
        inner: Box::new(inner),
        width,
    })
}

fn parse_plain_region(v: &Value, at: &str, origin: Origin) -> Result<Region, ControlError> {
    let obj = v.as_object().filter(|o| o.len() == 1).ok_or_else(|| {
        err(at, "expected one of {\"sphere\": {\"center\": [x,y,z], \"radius\": r}}, {\"box\": {\"min\": [..], \"max\": [..]}}, {\"vertices\": [i, ...]}, {\"group\": \"name\"}, {\"connected\": {\"distance\": d, \"from\": \"starts\"}}, {\"weights\": {\"vertices\": [i, ...], \"weights\": [w, ...]}}")
    })?;
    let (kind, body) = obj.iter().next().ok_or_else(|| err(at, "empty region"))?;
    let here = format!("{at}.{kind}");
    Ok(match kind.as_str() {
        "sphere" => {
            let center = point(body.get("center"), &format!("{here}.center"))?;
            let radius = body
                .get("radius")
                .and_then(Value::as_f64)
                .filter(|r| *r >= 0.0 && r.is_finite())
                .ok_or_else(|| err(&format!("{here}.radius"), "expected a number >= 0"))?;
            Region::Sphere { center, radius }
        }
        "box" => {
            let min = point(body.get("min"), &format!("{here}.min"))?;
            let max = point(body.get("max"), &format!("{here}.max"))?;
            if let Some(k) = (0..3).find(|&k| min[k] > max[k]) {
                return Err(err(
                    &format!("{here}.min[{k}]"),
                    format!(
                        "is greater than max[{k}] ({} > {}): the box is empty",
                        min[k], max[k]
                    ),
                ));
            }
            Region::Box { min, max }
        }
        "vertices" => Region::Vertices(indices(Some(body), &here)?),
        "connected" => parse_connected(body, &here, origin)?,
        "weights" => {
            let o = object_of(
                body,
                &here,
                &["vertices", "weights"],
                "{\"vertices\": [i, ...], \"weights\": [w, ...]}",
            )?;
            let vertices = indices(o.get("vertices"), &format!("{here}.vertices"))?;
            let wat = format!("{here}.weights");
            let list = o
                .get("weights")
                .and_then(Value::as_array)
                .ok_or_else(|| err(&wat, "expected a list of weights within [0, 1]"))?;
            if list.len() != vertices.len() {
                return Err(err(
                    &wat,
                    format!(
                        "{} weights for {} vertices: give one each",
                        list.len(),
                        vertices.len()
                    ),
                ));
            }
            let mut weights = Vec::with_capacity(list.len());
            for (i, x) in list.iter().enumerate() {
                let w = x
                    .as_f64()
                    .filter(|w| (0.0..=1.0).contains(w))
                    .ok_or_else(|| {
                        err(
                            &format!("{wat}[{i}]"),
                            format!("expected a weight within [0, 1], found {x}"),
                        )
                    })?;
                weights.push(w as f32);
            }
            Region::Weights { vertices, weights }
        }
        "group" => Region::Group(
            body.as_str()
                .ok_or_else(|| err(&here, "expected a part name"))?
                .to_owned(),
        ),
        other => {
            return Err(err(
                at,
                format!(
                    "unknown region {other:?}: expected sphere, box, vertices, group, connected or weights"
                ),
            ));
        }
    })
}

/// A list of vertex indices at `at`.
fn indices(v: Option<&Value>, at: &str) -> Result<Vec<u32>, ControlError> {
    let list = v
        .and_then(Value::as_array)
        .ok_or_else(|| err(at, "expected a list of vertex indices"))?;
    let mut out = Vec::with_capacity(list.len());
    for (i, x) in list.iter().enumerate() {
        let idx = x
            .as_u64()
            .filter(|&x| x <= u32::MAX as u64)
            .ok_or_else(|| {
                err(
                    &format!("{at}[{i}]"),
                    format!("expected a vertex index, found {x}"),
                )
            })?;
        out.push(idx as u32);
    }
    Ok(out)
}

/// The object at `at` (shaped like `shape`), refusing keys not in `keys`.
fn object_of<'a>(
    v: &'a Value,
    at: &str,
    keys: &[&str],
    shape: &str,
) -> Result<&'a Map<String, Value>, ControlError> {
    let o = v
        .as_object()
        .ok_or_else(|| err(at, format!("expected {shape}")))?;
    if let Some(k) = o.keys().find(|k| !keys.contains(&k.as_str())) {
        let names: Vec<String> = keys.iter().map(|k| format!("{k:?}")).collect();
        return Err(err(
            &format!("{at}.{k}"),
            format!("unknown key: expected {}", names.join(" and ")),
        ));
    }
    Ok(o)
}

/// `{"distance": d, "from": "starts" | "handle"}` (`from` defaults to `origin`).
fn parse_connected(body: &Value, at: &str, origin: Origin) -> Result<Region, ControlError> {
    let o = object_of(
        body,
        at,
        &["distance", "from"],
        "{\"distance\": d, \"from\": \"starts\" or \"handle\"}",
    )?;
    let dat = format!("{at}.distance");
    let distance = match o.get("distance") {
        None => {
            return Err(err(
                &dat,
                "missing: how far along the surface, in the mesh's units",
            ));
        }
        Some(d) => d
            .as_f64()
            .filter(|d| *d >= 0.0 && d.is_finite())
            .ok_or_else(|| {
                err(
                    &dat,
                    format!("expected a distance >= 0 along the surface, found {d}"),
                )
            })?,
    };
    let from = match o.get("from") {
        None | Some(Value::Null) => origin,
        Some(Value::String(f)) if f == "starts" => Origin::Starts,
        Some(Value::String(f)) if f == "handle" => Origin::Handle,
        Some(other) => {
            return Err(err(
                &format!("{at}.from"),
                format!("expected \"starts\" or \"handle\", found {other}"),
            ));
        }
    };
    Ok(Region::Connected { distance, from })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Broken JSON: the place said once, in front (serde_json's message
    /// ends with it too).
    #[test]
    fn broken_json_gives_its_place_once() {
        for (text, place) in [
            ("{\"radius\": 1,\n \"controls\": [\n", "line 3, column 0"),
            ("{\"radius\": 1 x}", "line 1, column 14"),
        ] {
            let e = ControlFile::parse(text).expect_err("not JSON").to_string();
            assert!(e.starts_with(place) && e.contains("invalid JSON: "), "{e}");
            assert!(!e.contains(" at line "), "{e}");
        }
    }

    #[test]
    fn the_issue_schema_and_defaults() {
        let f = ControlFile::parse(
            r#"{"kernel": "c4", "radius": 0.3, "polynomial": "none",
            "controls": [{"from": [0, 0, 0], "to": [1, 2, 3]}]}"#,
        )
        .expect("parse");
        let d = &f.deformations[0];
        assert_eq!(d.options.kernel, Kernel::C4);
        assert_eq!(d.options.polynomial, Polynomial::None);
        assert_eq!(d.targets[0], DVec3::new(1.0, 2.0, 3.0));
        let f = ControlFile::parse(
            r#"{"radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}], "extra": 1}"#,
        )
        .expect("parse");
        assert_eq!(f.deformations[0].options.kernel, Kernel::C2);
        assert_eq!(f.deformations[0].options.polynomial, Polynomial::None);
        assert_eq!(f.warnings, vec!["extra: unknown key ignored".to_owned()]);
    }

    #[test]
    fn a_misspelt_key_is_named_with_the_key_it_stands_for() {
        // Issue 42: `raduis` for `radius` is named where radius is missed.
        let e =
            ControlFile::parse(r#"{"raduis": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#)
                .expect_err("no radius");
        assert_eq!(e.location, "radius");
        assert!(
            e.message
                .starts_with("missing (the file has \"raduis\": a misspelling?)"),
            "{e}"
        );
        let e = ControlFile::parse(r#"{"radius": 1, "control": []}"#).expect_err("no controls");
        assert!(e.message.contains("\"control\": a misspelling?"), "{e}");
        let f = ControlFile::parse(
            r#"{"radius": 1, "kernal": "c4", "controls": [{"from": [0,0,0], "to": [0,0,0]}], "notes": 1}"#,
        )
        .expect("parse");
        assert_eq!(
            f.warnings,
            vec![
                "kernal (did you mean \"kernel\"?): unknown key ignored".to_owned(),
                "notes: unknown key ignored".to_owned()
            ]
        );
        assert_eq!(edit_distance("raduis", "radius"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(nearest_known("xy", KEYS), None);
    }

    #[test]
    fn chains_with_regions() {
        let f = ControlFile::parse(r#"{"deformations": [
            {"radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,1]}], "region": {"sphere": {"center": [0,0,0], "radius": 2}}},
            {"radius": 2, "kernel": "c0", "phase": 0.5, "controls": [{"from": [0,0,0], "to": [0,0,1]}], "region": {"group": "lips"}}]}"#)
        .expect("parse");
        assert_eq!(f.deformations.len(), 2);
        assert_eq!(f.deformations[1].region, Region::Group("lips".into()));
        assert_eq!(f.deformations[1].phase, 0.5);
    }

    /// Every field a deformation has survives writing and reading.
    #[test]
    fn files_round_trip_through_the_writer() {
        let mut a = ControlSpec::new(
            vec![DVec3::new(0.1, 0.2, 0.3), DVec3::ONE],
            vec![DVec3::new(0.1, 0.25, 0.3), DVec3::ONE],
            FitOptions::new(0.7)
                .with_kernel(Kernel::C4)
                .with_polynomial(Polynomial::Linear)
                .with_solver(SolverChoice::Skyline)
                .with_ordering(Ordering::BreadthFirst),
        );
        a.phase = 0.25;
        a.region = Region::Falloff {
            inner: Box::new(Region::Sphere {
                center: DVec3::ZERO,
                radius: 2.0,
            }),
            width: 0.5,
        };
        let mut b = ControlSpec::new(vec![], vec![], FitOptions::new(3.0));
        b.handle = Some(
            Handle::new(Region::Group("ear".into()))
                .with_rotation(Rotation::new(DVec3::Z, 30.0).with_pivot(DVec3::X))
                .with_scale(1.5)
                .with_translation(DVec3::Y)
                .with_samples(40),
        );
        b.anchor = Some(Region::Vertices(vec![1, 2, 3]));
        b.name = Some("left ear \"up\"".into());
        for file in [
            ControlFile::new(vec![a.clone()], Combine::Chain),
            ControlFile::new(vec![a, b], Combine::Add),
        ] {
            let back = ControlFile::parse(&file.to_text()).expect("reparse");
            assert_eq!(back, file);
        }
        let bad = ControlFile::parse(
            r#"{"name": 3, "radius": 1, "controls": [{"from": [0, 0, 0], "to": [0, 0, 1]}]}"#,
        );
        let e = bad.expect_err("a name must be a string");
        assert!(e.location.ends_with("name"), "{e}");
    }

    #[test]
    fn specs_and_stages_convert_both_ways() {
        let mut spec = ControlSpec::new(vec![DVec3::ZERO], vec![DVec3::X], FitOptions::new(2.0));
        spec.phase = 0.5;
        spec.region = Region::Group("lips".into());
        let stage = spec.to_stage().expect("stage");
        assert_eq!(ControlSpec::from(&stage), spec);
        spec.handle = Some(Handle::new(Region::All).with_scale(2.0));
        assert!(spec.to_stage().is_err());
    }

    #[test]
    fn regions_may_have_a_falloff() {
        let f = ControlFile::parse(
            r#"{"radius": 1, "region": {"box": {"min": [0,0,0], "max": [2,2,2]}, "falloff": 0.5},
                "controls": [{"from": [0,0,0], "to": [0,0,1]}]}"#,
        )
        .expect("parse");
        assert_eq!(
            f.deformations[0].region,
            Region::Falloff {
                inner: Box::new(Region::Box {
                    min: DVec3::ZERO,
                    max: DVec3::splat(2.0)
                }),
                width: 0.5
            }
        );
    }

    #[test]
    fn handles_become_control_vectors_on_the_mesh() {
        let f = ControlFile::parse(
            r#"{"radius": 3, "handle": {"select": {"box": {"min": [6, -1, -1], "max": [11, 1, 1]}},
                "rotate": {"axis": [0, 0, 1], "angle_deg": 90, "pivot": [5, 0, 0]}},
                "anchor": {"box": {"min": [-1, -1, -1], "max": [4, 1, 1]}}}"#,
        )
        .expect("parse");
        let spec = &f.deformations[0];
        assert!(spec.needs_mesh() && spec.starts.is_empty());
        let points: Vec<Vec3> = (0..=100)
            .map(|i| Vec3::new(i as f32 * 0.1, 0.0, 0.0))
            .collect();
        let r = spec.resolve(&points, &|_| None).expect("resolve");
        assert!(!r.needs_mesh() && r.starts.len() > 2);
        let tip = r
            .starts
            .iter()
            .position(|s| s.x == 10.0)
            .expect("the tip is sampled");
        assert!(r.targets[tip].distance(DVec3::new(5.0, 5.0, 0.0)) < 1e-9);
        // Pins do not move.
        assert!(
            r.starts
                .iter()
                .zip(&r.targets)
                .any(|(s, t)| s == t && s.x <= 4.0)
        );
    }

    #[test]
    fn errors_name_the_path() {
        let cases = [
            ("{", "line 1, column 1"),
            (
                r#"{"radius": 1, "kernel": "c3", "controls": []}"#,
                "kernel: unknown kernel \"c3\": expected one of c0, c2, c4, c6",
            ),
            (
                r#"{"radius": 1, "polynomial": "cubic", "controls": []}"#,
                "polynomial: unknown polynomial \"cubic\": expected one of none, linear",
            ),
            (
                r#"{"radius": 0, "controls": []}"#,
                "radius: must be a finite number > 0",
            ),
            (
                r#"{"radius": -2, "controls": []}"#,
                "radius: must be a finite number > 0",
            ),
            (r#"{"controls": []}"#, "radius: missing"),
            (
                r#"{"radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}, {"from": [0,0], "to": [1,1,1]}]}"#,
                "controls[1].from: expected three numbers",
            ),
            (
                r#"{"radius": 1, "controls": [{"from": [0,0,"a"], "to": [0,0,0]}]}"#,
                "controls[0].from[2]: expected a number",
            ),
            (
                r#"{"deformations": [{"radius": 1, "controls": [{"from": [0,0,0]}]}]}"#,
                "deformations[0].controls[0].to: missing",
            ),
            (
                r#"{"radius": 1, "phase": 3, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "phase: must be a number within [0, 1]",
            ),
            (
                r#"{"radius": 1, "region": {"cone": 1}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "unknown region \"cone\"",
            ),
            (
                r#"{"radius": 1, "region": {"box": {"min": [0,2,0], "max": [1,1,1]}}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "region.box.min[1]: is greater than max[1]",
            ),
            (
                r#"{"radius": 1, "region": {"sphere": {"center": [0,0,0], "radius": 1}, "falloff": 3}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "region.falloff: 3 is wider than the region itself (2 across)",
            ),
            (
                r#"{"radius": 1, "region": {"sphere": {"center": [0,0,0], "radius": 1}, "falloff": -1}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "region.falloff: expected a width > 0",
            ),
            (
                r#"{"combine": "blend", "deformations": [{"radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}]}"#,
                "combine: unknown combine \"blend\": expected chain or add",
            ),
            (
                r#"{"combine": 3, "radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "combine: expected \"chain\" or \"add\"",
            ),
            (
                r#"{"radius": 1, "anchor": {"group": "body"}, "controls": [{"from": [0,0,0], "to": [0,0,0]}]}"#,
                "anchor: an anchor needs a handle",
            ),
            (
                r#"{"radius": 1, "handle": {"select": {"group": "ear"}, "rotate": {"axis": [0,0,0], "angle_deg": 90}}}"#,
                "handle.rotate.axis: the axis must not be zero",
            ),
            (
                r#"{"radius": 1, "handle": {"select": {"group": "ear"}, "rotate": {"axis": [0,0,1]}}}"#,
                "handle.rotate.angle_deg: missing",
            ),
            (
                r#"{"radius": 1, "handle": {"select": {"group": "ear"}}}"#,
                "handle: the handle does not move",
            ),
            (
                r#"{"radius": 1, "handle": {"rotate": {"axis": [0,0,1], "angle_deg": 5}}}"#,
                "handle.select: missing",
            ),
            (
                r#"{"radius": 1, "handle": {"select": {"group": "ear"}, "scale": -1}}"#,
                "handle.scale: must be > 0",
            ),
            (
                r#"{"radius": 1, "handle": {"select": {"group": "ear"}, "scale": 2, "samples": 0}}"#,
                "handle.samples: expected a whole number",
            ),
        ];
        for (text, want) in cases {
            let e = ControlFile::parse(text)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(e.contains(want), "{text}: {e:?} does not contain {want:?}");
        }
    }

    /// Issue 23: a layer with no control vectors yet (an editor saves it
    /// before its first vector) is read, moves nothing, keeps the numbers of
    /// the layers after it, round-trips through `.csrbf`, and is said.
    #[test]
    fn a_layer_with_no_vectors_yet_is_work_in_progress() {
        let f = ControlFile::parse(
            r#"{"deformations": [{"radius": 0.5, "kernel": "c4", "controls": []},
                {"radius": 1, "controls": [{"from": [0,0,0], "to": [0,0,0.5]}]}]}"#,
        )
        .expect("parse");
        assert_eq!(
            f.warnings,
            vec!["deformations[0].controls: no control vectors yet: this deformation moves nothing until one is added".to_owned()]
        );
        let stages: Vec<_> = f
            .deformations
            .iter()
            .flat_map(|d| d.fit().expect("fit"))
            .collect();
        assert_eq!(stages.len(), 2);
        let pts = vec![
            glam::Vec3::new(0.1, 0.0, 0.0),
            glam::Vec3::new(5.0, 5.0, 5.0),
        ];
        let alone = csrbf::compose(&pts, &stages[..1], Combine::Chain).expect("compose");
        assert_eq!(alone, pts);
        let both = csrbf::compose(&pts, &stages, Combine::Chain).expect("compose");
        assert!(both[0].z > 0.3 && both[1] == pts[1]);
        let back =
            csrbf::format::decode(&csrbf::format::encode(&stages, Combine::Chain)).expect("decode");
        assert_eq!(back.stages, stages);
        // What a writer makes of it reads back the same.
        let again = ControlFile::parse(&f.to_text()).expect("parse again");
        assert_eq!(again.deformations, f.deformations);
    }
}
