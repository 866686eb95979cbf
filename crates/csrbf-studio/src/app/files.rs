//! Files around the app: a file dialog drawn in egui (no desktop portal is
//! needed, so it works under Xvfb and over SSH), the recent files, and the
//! recovery file written while a document has unsaved changes.

use std::path::{Path, PathBuf};

use eframe::egui;

/// What a file dialog is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    /// Open a mesh.
    OpenMesh,
    /// Open a control file on the current mesh.
    OpenControls,
    /// Save the control file.
    SaveControls,
    /// Export the deformed mesh.
    ExportMesh,
    /// Export the fitted deformations as `.csrbf`.
    ExportFitted,
    /// Open a scene in the Composer.
    OpenScene,
    /// Save the scene.
    SaveScene,
    /// Add a mesh to the scene as an object.
    AddObject,
    /// Choose a texture for the selected part.
    Texture,
    /// Add a control file to the selected part as a deformation.
    AddControls,
    /// Export the scene as a movie.
    ExportMovie,
    /// Export the scene as glTF.
    ExportGltf,
}

impl Purpose {
    fn title(self) -> &'static str {
        match self {
            Purpose::OpenMesh => "Open a mesh",
            Purpose::OpenControls => "Open a control file",
            Purpose::SaveControls => "Save the control file",
            Purpose::ExportMesh => "Export the deformed mesh",
            Purpose::ExportFitted => "Export the fitted deformation (.csrbf)",
            Purpose::OpenScene => "Open a scene",
            Purpose::SaveScene => "Save the scene",
            Purpose::AddObject => "Add a mesh to the scene",
            Purpose::Texture => "Choose a texture (PNG or JPEG)",
            Purpose::AddControls => "Add a deformation (control file)",
            Purpose::ExportMovie => "Export a movie (.mp4, .gif, or a folder for PNG frames)",
            Purpose::ExportGltf => "Export glTF (.glb)",
        }
    }

    fn saves(self) -> bool {
        matches!(
            self,
            Purpose::SaveControls
                | Purpose::ExportMesh
                | Purpose::ExportFitted
                | Purpose::SaveScene
                | Purpose::ExportMovie
                | Purpose::ExportGltf
        )
    }

    /// File name endings listed (others are hidden).
    fn endings(self) -> &'static [&'static str] {
        match self {
            Purpose::OpenMesh | Purpose::ExportMesh => PICKER_ENDINGS,
            Purpose::AddObject => MESH_ENDINGS,
            Purpose::OpenControls
            | Purpose::SaveControls
            | Purpose::OpenScene
            | Purpose::SaveScene
            | Purpose::AddControls => &["json"],
            Purpose::ExportFitted => &["csrbf"],
            Purpose::Texture => &["png", "jpg", "jpeg"],
            Purpose::ExportMovie => &["mp4", "gif"],
            Purpose::ExportGltf => &["glb", "gltf"],
        }
    }
}

/// The mesh formats read and written, by file name ending.
pub const MESH_ENDINGS: &[&str] = &["obj", "ply", "stl", "off", "gltf", "glb"];

/// The volume mesh formats the Picker opens (by their boundary) and exports
/// morphed ([`csrbf_mesh::volume::VolumeFormat`]'s).
pub const VOLUME_ENDINGS: &[&str] = &["vtk", "vtu", "msh"];

/// What the Picker opens and exports: surface and volume meshes.
const PICKER_ENDINGS: &[&str] = &[
    "obj", "ply", "stl", "off", "gltf", "glb", "vtk", "vtu", "msh",
];

/// An open file dialog.
pub struct FileDialog {
    /// What it is for.
    pub purpose: Purpose,
    dir: PathBuf,
    name: String,
    entries: Vec<(String, bool)>,
    error: Option<String>,
    /// The file name field takes the keyboard when the dialog opens.
    focus: bool,
    /// A file chosen for saving that exists: asked about before replacing.
    replace: Option<PathBuf>,
}

/// What the person did in the dialog.
pub enum Choice {
    /// Chose this file.
    File(PathBuf),
    /// Closed it.
    Cancel,
}

impl FileDialog {
    /// A dialog in the folder of `near` (or the working folder), with its
    /// file name filled in for saving.
    pub fn new(purpose: Purpose, near: Option<&Path>) -> FileDialog {
        let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
        let (dir, name) = match near {
            Some(p) if p.is_dir() => (p.to_path_buf(), String::new()),
            Some(p) => (
                p.parent()
                    .filter(|d| !d.as_os_str().is_empty())
                    .map(Path::to_path_buf)
                    .unwrap_or(cwd),
                if purpose.saves() {
                    p.file_name()
                        .map(|n| n.to_string_lossy().into_owned())
                        .unwrap_or_default()
                } else {
                    String::new()
                },
            ),
            None => (cwd, String::new()),
        };
        let mut d = FileDialog {
            purpose,
            dir,
            name,
            entries: Vec::new(),
            error: None,
            focus: true,
            replace: None,
        };
        d.list();
        d
    }

    fn list(&mut self) {
        self.entries.clear();
        match std::fs::read_dir(&self.dir) {
            Ok(rd) => {
                for e in rd.flatten() {
                    let name = e.file_name().to_string_lossy().into_owned();
                    if name.starts_with('.') {
                        continue;
                    }
                    let is_dir = e.path().is_dir();
                    let shown = is_dir
                        || name.rsplit_once('.').is_some_and(|(_, ext)| {
                            self.purpose
                                .endings()
                                .contains(&ext.to_ascii_lowercase().as_str())
                        });
                    if shown {
                        self.entries.push((name, is_dir));
                    }
                }
                self.entries
                    .sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
                self.error = None;
            }
            Err(e) => self.error = Some(format!("{}: {e}", self.dir.display())),
        }
    }

    fn enter(&mut self, dir: PathBuf) {
        self.dir = dir;
        self.list();
    }

    /// Draws the dialog; Some when the person chose or closed it.
    pub fn show(&mut self, ctx: &egui::Context) -> Option<Choice> {
        let mut choice = None;
        let mut open = true;
        egui::Window::new(self.purpose.title())
            .id(egui::Id::unique("file dialog"))
            .collapsible(false)
            .resizable(true)
            .default_size([560.0, 420.0])
            .anchor(egui::Align2::CENTER_CENTER, [0.0, 0.0])
            .open(&mut open)
            .show(ctx, |ui| {
                self.folder_ui(ui);
                ui.label(format!(
                    "Showing folders and {}",
                    self.purpose.endings().join(", ")
                ));
                let height = (ui.available_height() - 70.0).max(120.0);
                egui::ScrollArea::vertical()
                    .max_height(height)
                    .auto_shrink([false, false])
                    .show(ui, |ui| {
                        if let Some(c) = self.entries_ui(ui) {
                            choice = Some(c);
                        }
                    });
                if let Some(e) = &self.error {
                    ui.colored_label(egui::Color32::LIGHT_RED, e);
                }
                if let Some(c) = self.name_ui(ui) {
                    choice = Some(c);
                }
                if let Some(c) = self.replace_ui(ui) {
                    choice = Some(c);
                }
            });
        if !open {
            choice = Some(Choice::Cancel);
        }
        // Saving over a file that exists asks first (once for that file).
        if let Some(Choice::File(p)) = &choice
            && self.purpose.saves()
            && p.exists()
            && self.replace.as_ref() != Some(p)
        {
            self.replace = Some(p.clone());
            choice = None;
        }
        choice
    }

    /// Up, and the folder as text.
    fn folder_ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            if ui
                .button("Up")
                .on_hover_text("The folder above (Backspace)")
                .clicked()
                && let Some(p) = self.dir.parent()
            {
                let p = p.to_path_buf();
                self.enter(p);
            }
            let mut dir = self.dir.display().to_string();
            let r = ui.add(
                egui::TextEdit::singleline(&mut dir)
                    .desired_width(f32::INFINITY)
                    .id_salt("folder"),
            );
            if r.changed() {
                self.dir = PathBuf::from(&dir);
            }
            if r.lost_focus() {
                self.list();
            }
        });
    }

    /// The folder's entries: a click picks a file's name or enters a
    /// folder; a double click on a file chooses it.
    fn entries_ui(&mut self, ui: &mut egui::Ui) -> Option<Choice> {
        let mut go = None;
        for (name, is_dir) in &self.entries {
            let label = if *is_dir {
                format!("[{name}]")
            } else {
                name.clone()
            };
            let r = ui.selectable_label(!*is_dir && *name == self.name, label);
            if r.double_clicked() {
                go = Some((name.clone(), *is_dir, true));
            } else if r.clicked() {
                go = Some((name.clone(), *is_dir, false));
            }
        }
        match go {
            Some((name, true, _)) => {
                let d = self.dir.join(name);
                self.enter(d);
                None
            }
            Some((name, false, twice)) => {
                self.name = name;
                twice.then(|| Choice::File(self.dir.join(&self.name)))
            }
            None => None,
        }
    }

    /// The file's name (focused, selected, at first), Open or Save, Cancel.
    fn name_ui(&mut self, ui: &mut egui::Ui) -> Option<Choice> {
        let mut choice = None;
        ui.horizontal(|ui| {
            ui.label("File:");
            let out = egui::TextEdit::singleline(&mut self.name)
                .desired_width(300.0)
                .id_salt("file name")
                .show(ui);
            let r = out.response;
            if std::mem::take(&mut self.focus) {
                // Focused with the name selected: typing replaces it.
                r.request_focus();
                let mut state = out.state;
                state
                    .cursor
                    .set_char_range(Some(egui::text::CCursorRange::two(
                        egui::text::CCursor::new(0),
                        egui::text::CCursor::new(self.name.chars().count()),
                    )));
                state.store(ui.ctx(), r.id);
            }
            let enter = r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            let verb = if self.purpose.saves() { "Save" } else { "Open" };
            if (ui.button(verb).clicked() || enter) && !self.name.trim().is_empty() {
                let p = Path::new(self.name.trim());
                choice = Some(Choice::File(if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    self.dir.join(p)
                }));
            }
            if ui.button("Cancel").clicked() {
                choice = Some(Choice::Cancel);
            }
        });
        choice
    }

    /// Replace or keep a file that exists, when saving over one.
    fn replace_ui(&mut self, ui: &mut egui::Ui) -> Option<Choice> {
        let p = self.replace.clone()?;
        let mut choice = None;
        ui.horizontal(|ui| {
            ui.colored_label(egui::Color32::from_rgb(240, 190, 90), replace_question(&p));
            if ui.button("Replace").clicked() {
                choice = Some(Choice::File(p.clone()));
            }
            if ui.button("Keep it").clicked() {
                self.replace = None;
            }
        });
        choice
    }
}

/// "x exists. Replace it?", saying when it is read-only (replaced, it stays
/// read-only).
fn replace_question(p: &Path) -> String {
    let read_only = std::fs::metadata(p).is_ok_and(|m| m.permissions().readonly());
    if read_only {
        format!(
            "{} exists and is read-only. Replace it anyway (it stays read-only)?",
            p.display()
        )
    } else {
        format!("{} exists. Replace it?", p.display())
    }
}

/// The File menu's Recent submenu: the file clicked, if one was.
pub fn recent_menu(ui: &mut egui::Ui, recent: &[PathBuf]) -> Option<PathBuf> {
    let mut chosen = None;
    ui.menu_button("Recent", |ui| {
        for p in recent {
            if ui.button(p.display().to_string()).clicked() {
                chosen = Some(p.clone());
            }
        }
    });
    chosen
}

/// Where the app keeps its recent files and recovery file by default:
/// `$CSRBF_STUDIO_STATE`, else the platform's place for them (the `dirs`
/// convention) with `csrbf-studio` under it: on Linux `$XDG_STATE_HOME`,
/// else `~/.local/state`; on Windows `%APPDATA%` (the roaming application
/// data, `C:\Users\NAME\AppData\Roaming`); on macOS `~/Library/Application
/// Support`.
pub fn state_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("CSRBF_STUDIO_STATE") {
        return Some(PathBuf::from(d));
    }
    dirs::state_dir()
        .or_else(dirs::data_dir)
        .map(|d| d.join("csrbf-studio"))
}

/// The recent files, newest first (at most 10).
pub fn recent_files(dir: Option<&Path>) -> Vec<PathBuf> {
    let Some(dir) = dir else {
        return Vec::new();
    };
    std::fs::read_to_string(dir.join("recent.txt"))
        .map(|t| {
            t.lines()
                .filter(|l| !l.trim().is_empty())
                .map(PathBuf::from)
                .collect()
        })
        .unwrap_or_default()
}

/// Puts `path` first among the recent files.
pub fn remember(dir: Option<&Path>, path: &Path) {
    let Some(dir) = dir else {
        return;
    };
    let path = canonical(path);
    let mut list = recent_files(Some(dir));
    list.retain(|p| *p != path);
    list.insert(0, path);
    list.truncate(10);
    let text: String = list.iter().map(|p| format!("{}\n", p.display())).collect();
    let _ = std::fs::create_dir_all(dir);
    let _ = csrbf_mesh::write_atomic(&dir.join("recent.txt"), text.as_bytes());
}

/// `path` absolute with its links resolved, as people write it: Windows'
/// canonical form `\\?\C:\...` (what `canonicalize` gives there) without
/// its `\\?\`, which the recent files would otherwise show.
pub fn canonical(path: &Path) -> PathBuf {
    let p = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    without_verbatim(p)
}

/// `\\?\C:\x` as `C:\x`; any other path as it is.
fn without_verbatim(p: PathBuf) -> PathBuf {
    match p.to_str().and_then(|s| s.strip_prefix(r"\\?\")) {
        Some(rest) if rest.as_bytes().get(1) == Some(&b':') => PathBuf::from(rest),
        _ => p,
    }
}

/// The unsaved session kept in case the app dies: the mesh's path, the
/// control file's path (if it has one), and the control file's text.
#[derive(Clone, Debug, PartialEq)]
pub struct Recovery {
    /// The mesh.
    pub mesh: PathBuf,
    /// Where the control file was last saved, if ever.
    pub controls_path: Option<PathBuf>,
    /// The control file as it stood.
    pub controls: String,
}

impl Recovery {
    /// The recovery file's path in the state folder `dir`.
    pub fn path(dir: Option<&Path>) -> Option<PathBuf> {
        dir.map(|d| d.join("recovery.json"))
    }

    /// Reads the recovery file, if there is a readable one.
    pub fn load(dir: Option<&Path>) -> Option<Recovery> {
        let text = std::fs::read_to_string(Recovery::path(dir)?).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        Some(Recovery {
            mesh: PathBuf::from(v.get("mesh")?.as_str()?),
            controls_path: v
                .get("controls_path")
                .and_then(|p| p.as_str())
                .map(PathBuf::from),
            controls: v.get("controls")?.as_str()?.to_string(),
        })
    }

    /// Writes it, whole or not at all, on a thread of its own (the UI does
    /// not wait for the disk).
    pub fn store(&self, dir: Option<&Path>) {
        let Some(path) = Recovery::path(dir) else {
            return;
        };
        let v = serde_json::json!({
            "mesh": self.mesh.display().to_string(),
            "controls_path": self.controls_path.as_ref().map(|p| p.display().to_string()),
            "controls": self.controls,
        });
        write_in_background(path, serde_json::to_vec_pretty(&v).unwrap_or_default());
    }

    /// Removes the recovery file (the session was saved or closed on purpose).
    pub fn clear(dir: Option<&Path>) {
        if let Some(p) = Recovery::path(dir) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// The Composer's unsaved scene, kept in case the app dies: where it was
/// saved (if ever) and its text (paths as the document names them:
/// absolute for a scene never saved, relative to `path` otherwise).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneRecovery {
    /// Where the scene was opened from or last saved to.
    pub path: Option<PathBuf>,
    /// The scene file's text.
    pub scene: String,
}

impl SceneRecovery {
    /// The file's path in the state folder `dir`.
    pub fn path(dir: Option<&Path>) -> Option<PathBuf> {
        dir.map(|d| d.join("recovery.scene.json"))
    }

    /// Reads it, if there is a readable one.
    pub fn load(dir: Option<&Path>) -> Option<SceneRecovery> {
        let text = std::fs::read_to_string(SceneRecovery::path(dir)?).ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        Some(SceneRecovery {
            path: v.get("path").and_then(|p| p.as_str()).map(PathBuf::from),
            scene: v.get("scene")?.as_str()?.to_string(),
        })
    }

    /// Writes it on a thread, whole or not at all.
    pub fn store(&self, dir: Option<&Path>) {
        let Some(path) = SceneRecovery::path(dir) else {
            return;
        };
        let v = serde_json::json!({
            "path": self.path.as_ref().map(|p| p.display().to_string()),
            "scene": self.scene,
        });
        write_in_background(path, serde_json::to_vec_pretty(&v).unwrap_or_default());
    }

    /// Removes it.
    pub fn clear(dir: Option<&Path>) {
        if let Some(p) = SceneRecovery::path(dir) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Writes `bytes` to `path` (whole or not at all) on a thread of its own:
/// the UI does not wait for the disk.
fn write_in_background(path: PathBuf, bytes: Vec<u8>) {
    let _ = std::thread::Builder::new()
        .name("csrbf-recovery".into())
        .spawn(move || {
            if let Some(dir) = path.parent() {
                let _ = std::fs::create_dir_all(dir);
            }
            let _ = csrbf_mesh::write_atomic(&path, &bytes);
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_windows_canonical_path_loses_its_verbatim_prefix() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(
            without_verbatim(p(r"\\?\C:\scenes\face.json")),
            p(r"C:\scenes\face.json")
        );
        // A share (\\?\UNC\...) and a Unix path stay as they are.
        assert_eq!(without_verbatim(p(r"\\?\UNC\host\x")), p(r"\\?\UNC\host\x"));
        assert_eq!(
            without_verbatim(p("/home/a/face.json")),
            p("/home/a/face.json")
        );
    }

    #[cfg(unix)]
    #[test]
    fn replacing_a_read_only_file_says_so() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("csrbf-studio-ro-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let p = dir.join("x.json");
        std::fs::write(&p, "{}").expect("write");
        assert!(!replace_question(&p).contains("read-only"));
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o444)).expect("chmod");
        assert!(replace_question(&p).contains("is read-only"));
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).expect("chmod");
        std::fs::remove_dir_all(&dir).ok();
    }
}
