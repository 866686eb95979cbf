//! What the shell does with the Picker's files: a mesh opened (and what it
//! asks first), a control file opened, saved or restored from the recovery
//! file, the deformed mesh and the fitted `.csrbf` exported.

use std::path::Path;
use std::time::{Duration, Instant};

use std::sync::Arc;

use csrbf_edit::Note;
use csrbf_edit::controls::ControlFile;
use csrbf_mesh::Mesh;
use csrbf_mesh::volume::VolumeFormat;
use eframe::egui;

use super::files::{self, Purpose, Recovery};
use super::gpu;
use super::picker::{Gesture, Model};
use super::request::reason;
use super::studio::{Pending, StudioApp, is_scene};
use crate::Command;

impl StudioApp {
    /// Opens a mesh, replacing the document (after asking, if it has
    /// unsaved changes). A file that cannot be read leaves everything as it
    /// was and says why.
    pub fn open_mesh(&mut self, ctx: &egui::Context, path: &Path) {
        if self.picker.model.as_ref().is_some_and(|m| m.doc.dirty) {
            self.shell.pending = Some(Pending::Open(path.to_path_buf()));
            return;
        }
        self.open_mesh_now(ctx, path);
    }

    pub(super) fn open_mesh_now(&mut self, ctx: &egui::Context, path: &Path) {
        let started = Instant::now();
        if is_scene(path) {
            return self.open_scene(path);
        }
        // A volume mesh is edited by its boundary surface (vertex i is node
        // i); Export morphs every node and checks every cell.
        let (loaded, volume) = if VolumeFormat::is_volume_path(path) {
            let volume = match csrbf_mesh::volume::read(path) {
                Ok(v) => v,
                Err(e) => return self.show_error("Cannot open the mesh", reason(&e)),
            };
            let surface = csrbf_edit::volume::editing_surface(&volume);
            let solid = (0..volume.cells.len())
                .filter(|&c| volume.cells.kinds[c].dim() == 3)
                .count();
            let note = format!(
                "a volume mesh of {} nodes and {solid} 3D cells, shown by its boundary ({} faces); \
                 every node moves, and Export to {} writes it morphed with its cells checked",
                volume.points.len(),
                surface.faces.len(),
                VolumeFormat::EXTENSIONS
            );
            let loaded = csrbf_mesh::Loaded {
                mesh: surface,
                warnings: vec![note],
            };
            (loaded, Some(Arc::new(volume)))
        } else {
            match csrbf_mesh::load(path) {
                Ok(l) => (l, None),
                Err(e) => return self.show_error("Cannot open the mesh", reason(&e)),
            }
        };
        let mesh = loaded.mesh;
        if mesh.bounds().is_none() {
            return self.show_error(
                "Cannot open the mesh",
                format!("{}: the mesh has no vertices", path.display()),
            );
        }
        if mesh.faces.is_empty() {
            return self.show_error(
                "Cannot open the mesh",
                format!(
                    "{}: the mesh has no faces: the studio places controls on a surface{}",
                    path.display(),
                    if volume.is_some() {
                        " (a volume mesh's boundary: it has no 3D cells)"
                    } else {
                        ""
                    }
                ),
            );
        }
        if !(mesh.diagonal() > 0.0) {
            return self.show_error(
                "Cannot open the mesh",
                format!(
                    "{}: the mesh has no extent (its {} vertices are all at one point): \
                     nothing to place controls on, and no size to take a radius from",
                    path.display(),
                    mesh.positions.len()
                ),
            );
        }
        let size = self.screen.viewport.0;
        let scene = match csrbf_anim::still::mesh_scene(
            path,
            mesh.clone(),
            None,
            1.0,
            [size[0].max(16), size[1].max(16)],
        ) {
            Ok(s) => s,
            Err(e) => return self.show_error("Cannot open the mesh", reason(&e)),
        };
        let id = gpu::new_mesh_id();
        let mut model = Model::new(mesh, path, scene, (id, self.screen.software), size, ctx);
        model.volume = volume;
        let up = model.up;
        self.picker.model = Some(model);
        self.picker.gesture = Gesture::None;
        files::remember(self.shell.state.as_deref(), path);
        self.shell.recent = files::recent_files(self.shell.state.as_deref());
        let mut note = format!(
            "Opened {} in {:.0} ms; up axis {} ({})",
            path.display(),
            started.elapsed().as_secs_f64() * 1e3,
            csrbf_anim::camera::axis_name(up.0),
            up.1
        );
        for w in &loaded.warnings {
            note.push_str("; ");
            note.push_str(w);
        }
        self.picker.status = note;
    }

    /// Opens a control file on the current mesh, in the CLI's format. A file
    /// the CLI would refuse leaves the document as it was and says why.
    pub fn open_controls(&mut self, path: &Path) {
        if is_scene(path) {
            return self.open_scene(path);
        }
        let Some(m) = self.picker.model.as_mut() else {
            return self.show_error("No mesh", "open a mesh before its control file");
        };
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                return self.show_error(
                    "Cannot open the control file",
                    format!("{}: {e}", path.display()),
                );
            }
        };
        let file = match ControlFile::parse(&text) {
            Ok(f) => f,
            Err(e) => {
                return self.show_error(
                    "Cannot open the control file",
                    format!("{}: {e}", path.display()),
                );
            }
        };
        if file.deformations.is_empty() {
            return self.show_error(
                "Cannot open the control file",
                format!("{}: it has no deformation", path.display()),
            );
        }
        // What `csrbf deform` refuses on this mesh (starts that coincide, a
        // region or a handle the mesh cannot hold, a radius that reaches
        // nothing) is refused here too, in its words, before the document
        // changes: a refused file is never loaded, so never saved again.
        let source = path.display().to_string();
        if let Err(e) = csrbf_edit::fit(&file, &source, Some(&m.doc.mesh), false, &mut |_| {}) {
            return self.show_error("Cannot open the control file", reason(&e));
        }
        // Replacing the controls is one undoable step.
        let mut batch = Vec::new();
        let old = m.doc.controls.deformations.len();
        for (k, spec) in file.deformations.iter().enumerate() {
            batch.push(Command::InsertLayer {
                layer: old + k,
                spec: Box::new(spec.clone()),
            });
        }
        for k in (0..old).rev() {
            batch.push(Command::RemoveLayer { layer: k });
        }
        if let Err(e) = m.history.apply(&mut m.doc, Command::Batch(batch)) {
            return self.show_error("Cannot open the control file", reason(&e));
        }
        m.doc.controls.combine = file.combine;
        m.doc.selection.0.clear();
        m.doc.active_layer = 0;
        m.history.mark_saved(&mut m.doc);
        m.hidden = vec![false; m.doc.controls.deformations.len()];
        m.controls_path = Some(path.to_path_buf());
        let warnings = file.warnings.join("; ");
        self.picker.status = if warnings.is_empty() {
            format!("Opened {}", path.display())
        } else {
            format!("Opened {} (ignored: {warnings})", path.display())
        };
        self.picker.refresh(true);
        files::remember(self.shell.state.as_deref(), path);
        self.shell.recent = files::recent_files(self.shell.state.as_deref());
    }

    /// Saves the control file (to where it came from, else asks where).
    pub fn save(&mut self) {
        match self
            .picker
            .model
            .as_ref()
            .and_then(|m| m.controls_path.clone())
        {
            Some(p) => self.save_to(&p),
            None => self.ask(Purpose::SaveControls),
        }
    }

    /// Saves the control file to `path`, whole or not at all; a failure says
    /// so and keeps the document unsaved.
    pub fn save_to(&mut self, path: &Path) {
        let Some(m) = self.picker.model.as_mut() else {
            return;
        };
        let text = m.doc.to_text();
        match csrbf_mesh::write_atomic(path, text.as_bytes()) {
            Ok(()) => {
                m.history.mark_saved(&mut m.doc);
                m.controls_path = Some(path.to_path_buf());
                Recovery::clear(self.shell.state.as_deref());
                self.picker.status = format!("Saved {}", path.display());
                files::remember(self.shell.state.as_deref(), path);
                self.shell.recent = files::recent_files(self.shell.state.as_deref());
            }
            Err(e) => self.show_error("Cannot save", reason(&e)),
        }
    }

    /// Writes the deformed mesh as shown (any format the CLI writes).
    pub fn export_mesh(&mut self, path: &Path) {
        self.settle(Duration::from_secs(600));
        if VolumeFormat::is_volume_path(path) {
            return self.export_volume(path);
        }
        let Some(m) = self.picker.model.as_ref() else {
            return;
        };
        let mut mesh: Mesh = (*m.doc.mesh).clone();
        // The file's normals carried through the edit (a glTF's UV seams
        // and hard edges kept), computed where it had none.
        mesh.move_vertices(m.shown.to_vec());
        let of_volume = if m.volume.is_some() {
            format!(
                " (the volume's boundary faces, every node a vertex; {} keeps the cells)",
                VolumeFormat::EXTENSIONS
            )
        } else {
            String::new()
        };
        match csrbf_mesh::write(path, &mesh) {
            Ok(()) => self.picker.status = format!("Exported {}{of_volume}", path.display()),
            Err(e) => self.show_error("Cannot export the mesh", reason(&e)),
        }
    }

    /// Export of an open volume mesh to a volume format: every node moved
    /// by the document as shown (in f64, as `csrbf deform` moves it), every cell
    /// checked, the file written whole; the check said in the status, its
    /// advice in a dialog when cells turn inside out.
    fn export_volume(&mut self, path: &Path) {
        let Some(m) = self.picker.model.as_ref() else {
            return;
        };
        let Some(volume) = m.volume.clone() else {
            return self.show_error(
                "Cannot export the mesh",
                format!(
                    "{}: {} are volume formats, and {} is a surface mesh: export it as one of {}",
                    path.display(),
                    VolumeFormat::EXTENSIONS,
                    m.doc.mesh_path.display(),
                    super::files::MESH_ENDINGS
                        .iter()
                        .map(|e| format!(".{e}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            );
        };
        // What the viewport shows: hidden layers left out.
        let morph = csrbf_edit::volume::VolumeMorph::Controls(
            m.shown_controls(),
            "the document".to_owned(),
        );
        // The fit's warnings (a nearly dense system, a sweep that may
        // fold), as the CLI prints them.
        let mut warnings = Vec::new();
        let mut notes = |n: Note| {
            if let Note::Warning(w) = n {
                warnings.push(w);
            }
        };
        let morphed =
            morph
                .run(&volume, m.doc.phase, false, &mut notes)
                .and_then(|(moved, report)| {
                    let mut out = (*volume).clone();
                    out.points = moved;
                    csrbf_mesh::volume::write(path, &out)?;
                    Ok(report)
                });
        match morphed {
            Ok(report) => {
                let mut said = format!("Exported {}: {}", path.display(), report.summary());
                for w in &warnings {
                    said.push_str("; ");
                    said.push_str(w);
                }
                if report.advice.is_empty() {
                    self.picker.status = said;
                } else {
                    // Written, and what to do about its cells.
                    let title = if report.cells.inverted.is_empty() {
                        "Cells turn inside out on the way"
                    } else {
                        "Cells turn inside out"
                    };
                    self.show_error(title, format!("{said}.\n\n{}", report.advice));
                }
            }
            Err(e) => self.show_error("Cannot export the mesh", reason(&e)),
        }
    }

    /// Writes the fitted deformations as `.csrbf` (what `csrbf apply` reads).
    pub fn export_fitted(&mut self, path: &Path) {
        let Some(m) = self.picker.model.as_ref() else {
            return;
        };
        let fitted = csrbf_edit::fit(
            &m.doc.controls,
            "controls",
            Some(&m.doc.mesh),
            false,
            &mut |_| {},
        );
        let result = fitted.and_then(|edit| {
            let s: Vec<_> = edit
                .stages()
                .into_iter()
                .map(|s| {
                    let phase = s.phase * m.doc.phase;
                    s.with_phase(phase)
                })
                .collect();
            csrbf_edit::apply::save_replay(path, &s, m.doc.controls.combine, &m.doc.mesh)
        });
        match result {
            Ok(()) => self.picker.status = format!("Exported {}", path.display()),
            Err(e) => self.show_error("Cannot export the fitted deformation", reason(&e)),
        }
    }

    /// Reopens a recovered session: its mesh and its unsaved controls.
    pub fn restore(&mut self, ctx: &egui::Context, r: &Recovery) {
        let file = match ControlFile::parse(&r.controls) {
            Ok(f) => f,
            Err(e) => return self.show_error("Cannot restore", reason(&e)),
        };
        self.open_mesh_now(ctx, &r.mesh);
        let Some(m) = self.picker.model.as_mut() else {
            return;
        };
        m.doc.controls = file;
        m.history.mark_unsaved(&mut m.doc);
        m.controls_path = r.controls_path.clone();
        m.hidden = vec![false; m.doc.controls.deformations.len()];
        self.picker.status = format!("Restored the unsaved session on {}", r.mesh.display());
        self.picker.refresh(true);
    }

    /// The recovery file, while there are unsaved changes: at most once a
    /// second, and only when something changed.
    pub(super) fn write_recovery(&mut self) {
        let Some(m) = self.picker.model.as_mut() else {
            return;
        };
        if !m.doc.dirty
            || m.recovery_at
                .is_some_and(|t| t.elapsed() <= Duration::from_secs(1))
        {
            return;
        }
        m.recovery_at = Some(Instant::now());
        let text = m.doc.to_text();
        if m.recovered_text != text {
            Recovery {
                mesh: files::canonical(&m.doc.mesh_path),
                controls_path: m.controls_path.clone(),
                controls: text.clone(),
            }
            .store(self.shell.state.as_deref());
            m.recovered_text = text;
        }
    }
}
