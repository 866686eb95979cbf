//! The Picker's room: the model being edited and the tool, axis hold,
//! gesture and view settings its side panel ([`super::panel`]) and viewport
//! ([`super::viewport`]) work with, and the edits that need no file or
//! dialog (undo, redo, delete, duplicate, mirror, framing). The shell
//! opens and saves files through its fields; nothing here reaches back.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use csrbf::glam::{DVec3, Vec3};
use csrbf_mesh::{Bvh, Mesh, StandIn};
use eframe::egui;

use super::gpu;
use crate::gizmo::HandleDrag;
use crate::{Command, Document, DragTool, End, History, Orbit, Preview};

/// What a pointer press in the viewport does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Tool {
    /// A press on the surface adds a control vector there; dragging sets
    /// its destination (a click without a drag is a pin). Markers are
    /// dragged in any tool.
    Place,
    /// Presses select markers; a drag on the background draws a box.
    Select,
    /// A box on the surface selects vertices for a handle, a region or an
    /// anchor; a drag from the pivot rotates, scales or moves the handle.
    Vertices,
}

/// The loaded model and everything derived from it.
pub(super) struct Model {
    pub(super) doc: Document,
    pub(super) history: History,
    pub(super) preview: Preview,
    /// Where the control file was opened from or last saved to.
    pub(super) controls_path: Option<PathBuf>,
    /// Positions and normals drawn (the newest preview frame, else rest).
    pub(super) shown: Arc<Vec<Vec3>>,
    pub(super) shown_normals: Arc<Vec<Vec3>>,
    pub(super) rest_normals: Arc<Vec<Vec3>>,
    pub(super) rest_positions: Arc<Vec<Vec3>>,
    /// The picking tree, fitted to what the viewport draws when a press
    /// asks for the surface.
    pub(super) picking: Picking,
    pub(super) gpu_mesh: Arc<gpu::NewMesh>,
    /// For a big mesh: what is drawn while it moves (vertex clustering).
    pub(super) stand_in: Option<Arc<StandIn>>,
    /// Its frames were slow while it moved: moving pictures are drawn at
    /// half resolution ([`Model::moved_in`]).
    pub(super) light_while_moving: bool,
    pub(super) orbit: Orbit,
    /// The model's up axis and how it was found.
    pub(super) up: (Vec3, &'static str),
    /// The up direction being typed in the View menu.
    pub(super) up_text: String,
    /// Layers hidden from the preview (their phase taken as 0).
    pub(super) hidden: Vec<bool>,
    /// The planes Mirror reflects across, normal to X, Y and Z (the model's
    /// plane of symmetry when first needed; set in the side panel).
    pub(super) mirror_planes: [Option<f64>; 3],
    /// The plane of any orientation Mirror > Plane reflects across (the
    /// model's plane of symmetry, found from the mesh when first needed;
    /// typed, or through three starts, in the side panel).
    pub(super) mirror_any: Option<crate::symmetry::Plane>,
    /// Vertices chosen with the vertex tool (for a handle, region or anchor).
    pub(super) picked_vertices: Vec<u32>,
    /// What the last box of the vertex tool is for.
    pub(super) vertex_target: crate::tools::VertexTarget,
    /// The generation whose preview is shown.
    pub(super) shown_generation: u64,
    /// When the recovery file was last written.
    pub(super) recovery_at: Option<Instant>,
    /// Whether the view was framed for the viewport's real size.
    pub(super) framed: bool,
    /// The control file as last written to the recovery file.
    pub(super) recovered_text: String,
    /// The volume mesh the document's mesh is the boundary of (vertex i is
    /// node i), when a volume mesh was opened: what Export morphs.
    pub(super) volume: Option<Arc<csrbf_mesh::volume::VolumeMesh>>,
}

impl Model {
    /// The positions and normals the viewport draws: at rest in View > Rest,
    /// else the newest preview frame.
    pub(super) fn drawn(&self, display: Display) -> (&Arc<Vec<Vec3>>, &Arc<Vec<Vec3>>) {
        match display {
            Display::Rest => (&self.rest_positions, &self.rest_normals),
            Display::Deformed | Display::Both => (&self.shown, &self.shown_normals),
        }
    }

    /// The plane Mirror reflects across, normal to `axis`: the one set, else
    /// the model's plane of symmetry (found once).
    pub(super) fn mirror_plane(&mut self, axis: usize) -> Option<f64> {
        let slot = self.mirror_planes.get_mut(axis)?;
        if slot.is_none() {
            *slot = crate::symmetry::symmetry_plane(&self.doc.mesh.positions, axis);
        }
        *slot
    }

    /// The plane of any orientation Mirror > Plane reflects across: the one
    /// set, else the model's plane of symmetry (found once).
    pub(super) fn mirror_plane_any(&mut self) -> Option<crate::symmetry::Plane> {
        if self.mirror_any.is_none() {
            self.mirror_any = crate::symmetry::find_plane(&self.doc.mesh.positions);
        }
        self.mirror_any
    }

    /// The point to orbit about: the selected controls' starts' centre when
    /// `selection` is asked for and there is one, else None (the target).
    pub(super) fn orbit_pivot(&self, selection: bool) -> Option<Vec3> {
        let starts: Vec<DVec3> = (self.doc.selection.0.iter())
            .filter_map(|&(l, i)| {
                self.doc
                    .controls
                    .deformations
                    .get(l)?
                    .starts
                    .get(i)
                    .copied()
            })
            .collect();
        (selection && !starts.is_empty())
            .then(|| (starts.iter().sum::<DVec3>() / starts.len() as f64).as_vec3())
    }

    /// Orbits the view by a pointer move of `delta`, about the selection
    /// when `selection` says so (and there is one).
    pub(super) fn orbit_by(&mut self, delta: egui::Vec2, selection: bool) {
        match self.orbit_pivot(selection) {
            Some(p) => self.orbit.orbit_about(delta.x, delta.y, p),
            None => self.orbit.orbit(delta.x, delta.y),
        }
    }

    /// Shows the newest preview frame, if the worker made one.
    pub(super) fn take_frame(&mut self) {
        self.preview.poll();
        if let Some(f) = self.preview.latest()
            && f.generation != self.shown_generation
        {
            self.shown_generation = f.generation;
            self.shown = f.positions.clone();
            self.shown_normals = f.normals.clone();
            if self.picking.fits == Fits::Shown {
                self.picking.fits = Fits::Stale;
            }
        }
    }

    /// The model of `mesh` read from `path`: its document, the preview on a
    /// worker (waking `ctx`), the picking tree, normals, a stand-in when it
    /// is big, and a camera framing it for a viewport of `size`. `gpu`: the
    /// mesh's GPU id and whether the rasteriser is software.
    pub(super) fn new(
        mesh: Mesh,
        path: &Path,
        scene: csrbf_anim::Scene,
        (id, software): (u64, bool),
        size: [u32; 2],
        ctx: &egui::Context,
    ) -> Model {
        let up = csrbf_mesh::guess_up(&mesh, path);
        let (lo, hi) = mesh.bounds().unwrap_or_default();
        let diagonal = mesh.diagonal() as f64;
        let triangles = mesh.faces.triangles();
        let bvh = Bvh::new(&mesh.positions, &triangles);
        let rest_normals = Arc::new(csrbf_mesh::triangle_vertex_normals(
            &mesh.positions,
            &triangles,
        ));
        let shown = Arc::new(mesh.positions.clone());
        let big = triangles.len() > gpu::BIG_MESH_TRIANGLES;
        let stand_in = big.then(|| Arc::new(StandIn::new(&mesh.positions, &triangles)));
        let doc = Document::new(mesh, path.to_path_buf(), (diagonal * 0.15).max(1e-9));
        let wake = ctx.clone();
        let preview = Preview::new(&doc, move || wake.request_repaint());
        let aspect = size[0].max(1) as f32 / size[1].max(1) as f32;
        Model {
            hidden: vec![false; doc.controls.deformations.len()],
            history: History::default(),
            preview,
            controls_path: None,
            shown_normals: rest_normals.clone(),
            rest_positions: shown.clone(),
            rest_normals,
            shown,
            picking: Picking {
                bvh,
                fits: Fits::Shown,
                held: None,
            },
            gpu_mesh: Arc::new(gpu::NewMesh {
                id,
                scene: Mutex::new(Some(scene)),
                samples: if software || big { 1 } else { 4 },
            }),
            stand_in,
            light_while_moving: false,
            orbit: Orbit::new(up.0, lo, hi, if aspect.is_finite() { aspect } else { 1.6 }),
            up,
            mirror_planes: [None; 3],
            mirror_any: None,
            up_text: String::new(),
            picked_vertices: Vec::new(),
            vertex_target: crate::tools::VertexTarget::Handle,
            shown_generation: 0,
            recovery_at: None,
            framed: false,
            recovered_text: String::new(),
            volume: None,
            doc,
        }
    }
}

/// A mesh of more triangles than this is drawn by a stand-in while it moves
/// once its frames are slow ([`Model::moved_in`]); below, a stand-in (about
/// 50k triangles) would save little.
pub(super) const STAND_IN_FROM: usize = 100_000;

/// A whole frame slower than this while the model moves (under 20 fps).
pub(super) const SLOW_FRAME: Duration = Duration::from_millis(50);

impl Model {
    /// The document's control file as the preview shows it: hidden layers
    /// at phase 0.
    pub(super) fn shown_controls(&self) -> csrbf_edit::controls::ControlFile {
        let mut controls = self.doc.controls.clone();
        for (spec, &h) in controls.deformations.iter_mut().zip(&self.hidden) {
            if h {
                spec.phase = 0.0;
            }
        }
        controls
    }

    /// The model moved while frames cost `frame` (the whole frame, as the
    /// person sees it: [`gpu::Screen::frame_cost`]). At the first slow one, its moving
    /// pictures are drawn light from then on: at half resolution, and by a
    /// stand-in if it has over [`STAND_IN_FROM`] triangles (on lavapipe at
    /// 1280x800 an 84k-vertex sphere took 110 ms a frame, 50 ms light; a
    /// GPU never gets there).
    pub(super) fn moved_in(&mut self, frame: Option<Duration>) {
        if self.light_while_moving || frame.is_none_or(|f| f <= SLOW_FRAME) {
            return;
        }
        self.light_while_moving = true;
        if self.stand_in.is_none() && self.doc.mesh.faces.triangle_count() > STAND_IN_FROM {
            let triangles = self.doc.mesh.faces.triangles();
            self.stand_in = Some(Arc::new(StandIn::new(&self.doc.mesh.positions, &triangles)));
        }
    }
}

/// What the picking tree is fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Fits {
    /// The preview frame shown.
    Shown,
    /// The rest positions (View > Rest).
    Rest,
    /// A preview frame since replaced.
    Stale,
    /// The shape drawn when a start's drag began, held while the start
    /// moves: the surface under the pointer must not be the one the move
    /// itself deforms (the start drifted off the pointer, path by path).
    Held,
}

/// The picking tree of a model, refitted (not rebuilt) to what the viewport
/// draws when a press needs the surface: a refit of a big mesh costs
/// milliseconds, so it waits until then.
pub(super) struct Picking {
    pub(super) bvh: Bvh,
    pub(super) fits: Fits,
    /// The positions of [`Fits::Held`].
    pub(super) held: Option<Arc<Vec<Vec3>>>,
}

impl Picking {
    /// The tree fitted to `drawn`, which the viewport draws for `display`.
    pub(super) fn fitted(&mut self, display: Display, drawn: &[Vec3]) -> &Bvh {
        let want = match display {
            Display::Rest => Fits::Rest,
            Display::Deformed | Display::Both => Fits::Shown,
        };
        if self.fits != want {
            self.bvh.refit(drawn);
            self.fits = want;
        }
        &self.bvh
    }

    /// Fits the tree to `drawn` (what `display` draws now) and holds it
    /// there until [`Picking::let_go`].
    pub(super) fn hold(&mut self, display: Display, drawn: &Arc<Vec<Vec3>>) {
        self.fitted(display, drawn);
        self.fits = Fits::Held;
        self.held = Some(drawn.clone());
    }

    /// The held tree and its positions, if the tree is held.
    pub(super) fn held(&self) -> Option<(&Bvh, &[Vec3])> {
        match (&self.held, self.fits) {
            (Some(p), Fits::Held) => Some((&self.bvh, p)),
            _ => None,
        }
    }

    /// Lets the held tree go: the next pick refits it to what is drawn.
    pub(super) fn let_go(&mut self) {
        if self.fits == Fits::Held {
            self.fits = Fits::Stale;
        }
        self.held = None;
    }
}

/// The Picker's room: the model and the tool, axis hold, gesture, handle
/// mode and view settings its panel and viewport work with.
pub(super) struct Picker {
    pub(super) model: Option<Model>,
    pub(super) tool: Tool,
    pub(super) axis: Option<usize>,
    pub(super) view: ViewSettings,
    pub(super) gesture: Gesture,
    pub(super) handle_mode: crate::gizmo::HandleMode,
    /// The next press on the surface puts the active handle's pivot there.
    pub(super) pick_pivot: bool,
    /// The status line while the Picker is shown.
    pub(super) status: String,
}

/// What is shown of the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Display {
    /// Deformed.
    Deformed,
    /// At rest.
    Rest,
    /// Deformed, with the rest shape's edges as a ghost.
    Both,
}

/// The viewport's display settings.
#[derive(Clone, Debug)]
pub(super) struct ViewSettings {
    pub display: Display,
    pub wireframe: bool,
    pub flat: bool,
    pub starts: bool,
    pub arrows: bool,
    /// Support spheres of the selection.
    pub spheres: bool,
    pub gizmo: bool,
    /// Show every support sphere of the active layer (while the radius slider moves).
    pub all_spheres: bool,
    /// A displacement to stamp on the next clicks (Duplicate).
    pub stamp: Option<DVec3>,
    /// The vertex brush's radius, as a share of the model's diagonal.
    pub brush: f32,
    /// A box of the vertex tool takes every vertex in it, not only those
    /// facing the camera (X-ray).
    pub xray: bool,
    /// Orbit about the selected controls' starts, not the view's target.
    pub orbit_selection: bool,
}

impl Default for ViewSettings {
    fn default() -> Self {
        ViewSettings {
            display: Display::Deformed,
            wireframe: false,
            flat: false,
            starts: true,
            arrows: true,
            spheres: true,
            gizmo: true,
            all_spheres: false,
            stamp: None,
            brush: 0.03,
            xray: false,
            orbit_selection: false,
        }
    }
}

/// A pointer gesture in progress.
#[derive(Clone, Debug)]
pub(super) enum Gesture {
    None,
    /// Moving one end of a control vector.
    Marker {
        layer: usize,
        index: usize,
        end: End,
        tool: DragTool,
        moved: bool,
    },
    /// A selection box from this point (in points).
    Box {
        from: egui::Pos2,
        add: bool,
    },
    /// Turning, scaling or moving a handle about its pivot.
    /// A handle's gizmo dragged (a ring turned, or the pivot rotated,
    /// scaled or moved).
    Handle {
        layer: usize,
        drag: Box<HandleDrag>,
    },
    Orbit,
    Pan,
    /// Painting vertices under a brush (Vertices tool with Ctrl).
    Brush,
}

impl Picker {
    /// Applies an edit; `full`: refit and diagnose (else a drag step).
    pub(super) fn edit(&mut self, command: Command, full: bool) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        match m.history.apply(&mut m.doc, command) {
            Ok(()) => {
                m.hidden.resize(m.doc.controls.deformations.len(), false);
                // A refusal of an earlier value no longer holds.
                if self.status.starts_with("Not done") {
                    self.status.clear();
                }
                self.refresh(full);
            }
            Err(e) => self.status = format!("Not done: {e}"),
        }
    }

    /// Undoes the last edit (`redo`: redoes the last undone).
    pub(super) fn undo(&mut self, redo: bool) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let done = if redo {
            m.history.redo(&mut m.doc)
        } else {
            m.history.undo(&mut m.doc)
        };
        match done {
            Ok(()) => {
                m.hidden.resize(m.doc.controls.deformations.len(), false);
                self.status = if redo { "Redone" } else { "Undone" }.into();
                self.refresh(true);
            }
            Err(e) => self.status = e.to_string(),
        }
    }

    /// Sends the document, as the preview should show it, to the worker.
    pub(super) fn refresh(&mut self, full: bool) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        if m.hidden.iter().any(|&h| h) {
            let mut shown = m.doc.clone();
            shown.controls = m.shown_controls();
            m.preview.edit(&shown, full);
        } else {
            m.preview.edit(&m.doc, full);
        }
    }

    pub(super) fn set_axis(&mut self, axis: Option<usize>) {
        self.axis = axis;
        self.status = match axis {
            Some(a) => format!(
                "Moves held to the {} axis (press it again to free)",
                ["X", "Y", "Z"][a]
            ),
            None => "Moves free on the plane facing the camera".into(),
        };
    }

    /// Frames the selection (`selection`) or the whole model.
    pub(super) fn frame_view(&mut self, selection: bool, size: [u32; 2]) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let mut pts: Vec<Vec3> = Vec::new();
        if selection {
            for &(l, i) in &m.doc.selection.0 {
                if let Some(s) = m.doc.controls.deformations.get(l) {
                    let r = s.options.radius as f32;
                    for p in [s.starts.get(i), s.targets.get(i)].into_iter().flatten() {
                        pts.push(p.as_vec3() - Vec3::splat(r * 0.5));
                        pts.push(p.as_vec3() + Vec3::splat(r * 0.5));
                    }
                }
            }
        }
        if pts.is_empty() {
            pts = m.shown.to_vec();
        }
        let lo = pts.iter().copied().fold(Vec3::INFINITY, Vec3::min);
        let hi = pts.iter().copied().fold(Vec3::NEG_INFINITY, Vec3::max);
        m.orbit
            .frame(lo, hi, size[0].max(1) as f32 / size[1].max(1) as f32);
    }

    pub(super) fn select_all(&mut self) {
        if let Some(m) = self.model.as_mut() {
            let l = m.doc.active_layer;
            let n = m
                .doc
                .controls
                .deformations
                .get(l)
                .map_or(0, |s| s.starts.len());
            m.doc.selection.0 = (0..n).map(|i| (l, i)).collect();
        }
    }

    pub(super) fn delete_selected(&mut self) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let mut sel = m.doc.selection.0.clone();
        if sel.is_empty() {
            return;
        }
        // Highest index first, so the others keep theirs.
        sel.sort_unstable();
        sel.dedup();
        let batch = sel
            .iter()
            .rev()
            .map(|&(layer, index)| Command::Remove { layer, index })
            .collect();
        m.doc.selection.0.clear();
        let n = sel.len();
        self.edit(Command::Batch(batch), true);
        self.status = format!("Deleted {}", count(n, "control vector", "control vectors"));
    }

    /// Copies the selected controls' displacements onto the next clicks
    /// on the surface (a stamp): the way to repeat an edit elsewhere.
    pub(super) fn duplicate(&mut self) {
        let Some(m) = self.model.as_ref() else {
            return;
        };
        let Some(&(l, i)) = m.doc.selection.0.last() else {
            self.status = "Select a control vector to duplicate".into();
            return;
        };
        let s = &m.doc.controls.deformations[l];
        let d = s.targets[i] - s.starts[i];
        self.gesture = Gesture::None;
        self.view.stamp = Some(d);
        self.tool = Tool::Place;
        self.status = "Click on the surface to place a copy (Esc to stop)".into();
    }

    /// Mirrors the selected controls (or all of the active layer) across
    /// the mirror plane normal to `axis` (0 X, 1 Y, 2 Z), or with `axis` 3
    /// across the plane of any orientation; the images of starts on the
    /// surface are put on it, and the status says when that moved one far
    /// (the model is not symmetric about the plane there).
    pub(super) fn mirror(&mut self, axis: usize) {
        let Some(m) = self.model.as_mut() else {
            return;
        };
        let (plane, name) = if axis < 3 {
            let Some(c) = m.mirror_plane(axis) else {
                return;
            };
            let Some(plane) = crate::symmetry::Plane::axis(axis, c) else {
                return;
            };
            (
                plane,
                format!("the plane {} = {c:.4}", ["X", "Y", "Z"][axis]),
            )
        } else {
            let Some(plane) = m.mirror_plane_any() else {
                return;
            };
            let (p, n) = (plane.point, plane.normal);
            (
                plane,
                format!(
                    "the plane through ({:.4}, {:.4}, {:.4}) normal to ({:.3}, {:.3}, {:.3})",
                    p.x, p.y, p.z, n.x, n.y, n.z
                ),
            )
        };
        let Some(mirrored) = Command::mirror_across(&m.doc, &plane) else {
            self.status = "Nothing to mirror: every image is already there".into();
            return;
        };
        let (n, far) = (mirrored.added, mirrored.largest_gap());
        self.edit(mirrored.command, true);
        self.status = format!(
            "Mirrored {} across {name}",
            count(n, "control vector", "control vectors")
        );
        if far > MIRROR_GAP {
            self.status += &format!(
                "; an image lay {:.0} % of R off the surface and was put on it: is the model symmetric about this plane?",
                100.0 * far
            );
        }
    }
}

/// How far (in R) an image may lie off the surface before Mirror says so.
const MIRROR_GAP: f64 = 0.05;

/// `n` things, named in the singular for one: "1 face", "2 faces".
pub(super) fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model of a sphere of about `triangles` triangles.
    fn sphere_model(triangles: usize) -> Model {
        let rings = ((triangles / 4) as f64).sqrt().round() as u32;
        let mesh = csrbf_mesh::shapes::uv_sphere(1.0, rings, 2 * rings);
        let path = Path::new("sphere.ply");
        let scene = csrbf_anim::still::mesh_scene(path, mesh.clone(), None, 1.0, [64, 48])
            .expect("a scene");
        Model::new(
            mesh,
            path,
            scene,
            (1, true),
            [64, 48],
            &egui::Context::default(),
        )
    }

    #[test]
    fn slow_frames_while_moving_make_the_moving_pictures_light() {
        let mut small = sphere_model(20_000);
        small.moved_in(None);
        small.moved_in(Some(SLOW_FRAME));
        assert!(!small.light_while_moving, "not slow yet");
        small.moved_in(Some(SLOW_FRAME * 2));
        assert!(small.light_while_moving);
        assert!(small.stand_in.is_none(), "too small to need a stand-in");

        let mut big = sphere_model(STAND_IN_FROM + 20_000);
        assert!(big.doc.mesh.faces.triangle_count() > STAND_IN_FROM);
        assert!(
            big.stand_in.is_none(),
            "not big enough to have one from the start"
        );
        big.moved_in(Some(SLOW_FRAME * 2));
        assert!(big.light_while_moving);
        let light = big.stand_in.as_ref().expect("a stand-in once slow");
        assert!(light.indices.len() / 3 < big.doc.mesh.faces.triangle_count() / 2);
    }

    #[test]
    fn one_thing_is_named_in_the_singular() {
        assert_eq!(count(1, "face", "faces"), "1 face");
        assert_eq!(count(0, "face", "faces"), "0 faces");
        assert_eq!(count(2, "vertex", "vertices"), "2 vertices");
    }
}
