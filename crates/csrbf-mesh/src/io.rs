//! Reading and writing files: format by extension, validation on read,
//! whole-or-nothing writes.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::formats::Skipped;
use crate::{Format, Mesh, MeshError, Result};

/// Reads and validates a mesh; the format comes from the extension.
pub fn read(path: &Path) -> Result<Mesh> {
    load(path).map(|l| l.mesh)
}

/// A mesh with what was odd about its file but not wrong enough to refuse.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The mesh.
    pub mesh: Mesh,
    /// Warnings naming the file, e.g. a text file cut in the middle of a line.
    pub warnings: Vec<String>,
}

/// Reads and validates a mesh, and says what looked wrong without being an
/// error: what the file holds that a mesh does not keep (an OBJ's lines
/// and points, a PLY's other elements and properties, an OFF's face
/// colours); a text format with no line break at its end may have been cut off;
/// an OBJ's material library or texture that is missing, unreadable,
/// malformed or outside the model's folder (the mesh loads, those materials
/// grey or without their picture).
pub fn load(path: &Path) -> Result<Loaded> {
    let format = Format::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|source| MeshError::Read {
        path: path.to_owned(),
        source,
    })?;
    let mut skipped = Skipped::default();
    let mut mesh = Mesh::from_bytes_noting(&bytes, format, path, &mut skipped)?;
    let mut warnings: Vec<String> = skipped.warning(path).into_iter().collect();
    if format == Format::Obj {
        crate::formats::materials::read_beside(path, &mut mesh, &mut warnings);
    }
    let text =
        matches!(format, Format::Obj | Format::Off) || bytes.starts_with(b"ply\nformat ascii");
    if text && !bytes.is_empty() && !bytes.ends_with(b"\n") {
        warnings.push(format!(
            "{}: the file does not end with a line break; it may have been cut off",
            path.display()
        ));
    }
    Ok(Loaded { mesh, warnings })
}

/// Writes a mesh whole or not at all; the format comes from the extension.
/// An OBJ's side files are written as [`write_with`] does by default (what
/// is left alone is not said: use [`write_with`] to hear it).
pub fn write(path: &Path, mesh: &Mesh) -> Result<()> {
    write_with(path, mesh, &WriteOptions::default()).map(|_| ())
}

/// How [`write_with`] treats files in the way.
#[derive(Clone, Debug, Default)]
#[non_exhaustive]
pub struct WriteOptions {
    /// Replace an OBJ's side files (a `.mtl` that csrbf did not write, a
    /// texture of the same name with other bytes) instead of leaving them
    /// alone. Default false.
    pub force: bool,
}

impl WriteOptions {
    /// Sets [`WriteOptions::force`].
    pub fn with_force(mut self, force: bool) -> WriteOptions {
        self.force = force;
        self
    }
}

/// What [`write_with`] did.
#[derive(Clone, Debug, Default, PartialEq)]
#[non_exhaustive]
pub struct Written {
    /// Every file the output consists of, the mesh first: for an OBJ its
    /// material library and textures too (written, or already there with
    /// the same bytes).
    pub files: Vec<PathBuf>,
    /// Side files left alone, each naming the file, what the output lacks
    /// as a result, and `--force`.
    pub warnings: Vec<String>,
}

/// Writes a mesh whole or not at all; the format comes from the extension.
///
/// An OBJ with material parts names a material library beside it: the one
/// its materials were read from when the OBJ goes into that same folder;
/// else `STEM.mtl`, written with its textures (`STEM_K.png` or `.jpg`).
/// A file csrbf did not write is never replaced unless `options.force`: a
/// `STEM.mtl` without csrbf's header comment (the OBJ then names no
/// library), a texture whose bytes differ (the library then gives that
/// material its colour only); each case is a warning in [`Written`].
/// The side files and the OBJ are all written to temporaries first and
/// renamed only when every one is complete, the OBJ last, so it never
/// names a library that is not there.
pub fn write_with(path: &Path, mesh: &Mesh, options: &WriteOptions) -> Result<Written> {
    let format = Format::from_path(path)?;
    if format != Format::Obj {
        let bytes = mesh.to_bytes_for(format, path)?;
        write_atomic(path, &bytes)?;
        return Ok(Written {
            files: vec![path.to_owned()],
            warnings: Vec::new(),
        });
    }
    mesh.validate(path)?;
    let mut written = Written::default();
    let mut side: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let library = obj_library(path, mesh, options, &mut side, &mut written)?;
    let obj = crate::formats::obj::encode(mesh, library.as_deref());
    let mut all: Vec<(&Path, &[u8])> = side
        .iter()
        .map(|(p, b)| (p.as_path(), b.as_slice()))
        .collect();
    all.push((path, &obj));
    write_all_atomic(&all)?;
    written.files.insert(0, path.to_owned());
    Ok(written)
}

/// Plans the material library an OBJ at `path` names, if it needs one:
/// the files to write go into `side`, those kept or unchanged into
/// `written.files`, what is left alone into `written.warnings`; returns the
/// name for its `mtllib` line.
fn obj_library(
    path: &Path,
    mesh: &Mesh,
    options: &WriteOptions,
    side: &mut Vec<(PathBuf, Vec<u8>)>,
    written: &mut Written,
) -> Result<Option<String>> {
    use crate::formats::obj;
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let stem = path
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy());
    let Some(mut lib) = obj::library(mesh, &stem) else {
        return Ok(None);
    };
    if let Some(kept) = reusable_library(mesh, dir) {
        return Ok(Some(kept));
    }
    let name = format!("{stem}.mtl");
    // Beside the OBJ, named as the user named it (`b.mtl`, not `./b.mtl`).
    let target = path.with_file_name(&name);
    let ours = |p: &Path| std::fs::read(p).is_ok_and(|b| b.starts_with(obj::WRITTEN_BY.as_bytes()));
    if target.exists() && !options.force && !ours(&target) {
        let names: Vec<&str> = lib.materials.iter().map(|m| m.name.as_str()).collect();
        written.warnings.push(format!(
            "{}: exists and was not written by csrbf, so it is left alone: {} names no material library, so its materials ({}) have no colour or texture in other programs; pass --force (force=True in Python) to replace it",
            target.display(),
            path.display(),
            names.join(", ")
        ));
        return Ok(None);
    }
    let mut textures = Vec::new();
    for m in &mut lib.materials {
        let Some((file, bytes)) = &m.texture else {
            continue;
        };
        let at = path.with_file_name(file);
        match std::fs::read(&at) {
            Ok(old) if old == *bytes => textures.push(at),
            Ok(_) | Err(_) if at.exists() && !options.force => {
                written.warnings.push(format!(
                    "{}: exists with other content, so it is left alone: {} gives material {} its colour but not its texture; pass --force (force=True in Python) to replace it",
                    at.display(),
                    target.display(),
                    m.name
                ));
                m.texture = None;
            }
            _ => {
                textures.push(at.clone());
                side.push((at, bytes.clone()));
            }
        }
    }
    written.files.push(target.clone());
    written.files.extend(textures);
    side.push((target, lib.text().into_bytes()));
    Ok(Some(name))
}

/// The `mtllib` line the mesh was read with, when an OBJ in `dir` would
/// find through it exactly the library files its materials came from
/// (an output beside its input): naming them keeps what csrbf does not read.
fn reusable_library(mesh: &Mesh, dir: &Path) -> Option<String> {
    let line = mesh.material_library.as_ref()?;
    if mesh.material_files.is_empty() {
        return None;
    }
    let names = crate::formats::materials::library_names(line, dir);
    let found: Option<Vec<PathBuf>> = names
        .iter()
        .map(|n| std::fs::canonicalize(dir.join(n)).ok())
        .collect();
    (found.as_ref() == Some(&mesh.material_files)).then(|| line.clone())
}

/// The prefix of every temporary file csrbf writes (`.csrbf-PID-N.tmp`).
pub const TEMP_PREFIX: &str = ".csrbf-";

/// A temporary name beside `path`, short (a legal 255-byte output name must
/// not fail for its temporary's sake) and naming this process, so a later
/// run can tell a stale one; the folder must exist.
pub fn temp_beside(path: &Path) -> std::io::Result<PathBuf> {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            format!("the output folder {} does not exist", dir.display()),
        ));
    }
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    Ok(dir.join(format!("{TEMP_PREFIX}{}-{n}.tmp", std::process::id())))
}

/// Temporaries being written right now, for [`remove_live_temps`].
static LIVE: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Notes a temporary file or folder being written, so an interruption can
/// remove it ([`remove_live_temps`]).
pub fn track_temp(path: &Path) {
    if let Ok(mut live) = LIVE.lock() {
        live.push(path.to_owned());
    }
}

/// The temporary is renamed or removed: no longer ours to clean up.
pub fn untrack_temp(path: &Path) {
    if let Ok(mut live) = LIVE.lock() {
        live.retain(|p| p != path);
    }
}

/// Removes every temporary still being written (on SIGINT or SIGTERM).
pub fn remove_live_temps() {
    if let Ok(mut live) = LIVE.lock() {
        for p in live.drain(..) {
            let _ = std::fs::remove_file(&p).or_else(|_| std::fs::remove_dir_all(&p));
        }
    }
}

/// Removes temporaries that an earlier run of csrbf left in `dir` when it
/// was killed (`.csrbf-PID-...` whose process is gone). Where a process's
/// life cannot be seen (no `/proc`), nothing is removed.
pub fn remove_stale_temps(dir: &Path) -> usize {
    if !Path::new("/proc/self").exists() {
        return 0;
    }
    let Ok(entries) = std::fs::read_dir(dir) else {
        return 0;
    };
    let mut removed = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(pid) = name
            .strip_prefix(TEMP_PREFIX)
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        if pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        let p = e.path();
        if std::fs::remove_file(&p)
            .or_else(|_| std::fs::remove_dir_all(&p))
            .is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Writes `bytes` to a temporary file beside `path`, flushes it to disk,
/// then renames it over `path`: a reader never sees a partial file, and a
/// failure leaves any old file as it was. A file replaced keeps its
/// permissions (a read-only file stays read-only; on Windows, where a
/// read-only file cannot be replaced, the error says so).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    write_all_atomic(&[(path, bytes)])
}

/// Writes several files as [`write_atomic`] does one: every temporary is
/// written and flushed before any is renamed, so a failure while writing
/// (a full disk) changes none of them; the renames go in the order given.
pub fn write_all_atomic(files: &[(&Path, &[u8])]) -> Result<()> {
    let mut staged: Vec<PathBuf> = Vec::with_capacity(files.len());
    let mut result = Ok(());
    for &(path, bytes) in files {
        match stage(path, bytes) {
            Ok(tmp) => staged.push(tmp),
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    if result.is_ok() {
        for (k, (&(path, _), tmp)) in files.iter().zip(&staged).enumerate() {
            if let Err(source) = replace(tmp, path) {
                result = Err(MeshError::Io {
                    path: path.to_owned(),
                    source,
                });
                for rest in &staged[k..] {
                    let _ = std::fs::remove_file(rest);
                }
                break;
            }
        }
    } else {
        for tmp in &staged {
            let _ = std::fs::remove_file(tmp);
        }
    }
    for tmp in &staged {
        untrack_temp(tmp);
    }
    result
}

/// Writes and flushes the temporary that will become `path`, with the
/// permissions of the file it replaces; tracked until renamed or removed.
fn stage(path: &Path, bytes: &[u8]) -> Result<PathBuf> {
    let io = |source| MeshError::Io {
        path: path.to_owned(),
        source,
    };
    let tmp = temp_beside(path).map_err(io)?;
    track_temp(&tmp);
    let kept = std::fs::metadata(path).ok().map(|m| m.permissions());
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        if let Some(permissions) = kept.filter(|_| cfg!(unix)) {
            std::fs::set_permissions(&tmp, permissions)?;
        }
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        untrack_temp(&tmp);
        return Err(io(e));
    }
    Ok(tmp)
}

/// Moves the finished temporary `tmp` over `path` (a rename: whole or not
/// at all). Windows refuses to replace a file that another program holds
/// open (an image viewer, a DCC tool); the error then says so and that the
/// old file is kept, instead of the bare "Access is denied".
pub fn replace(tmp: &Path, path: &Path) -> std::io::Result<()> {
    std::fs::rename(tmp, path).map_err(|e| {
        let read_only = std::fs::metadata(path).is_ok_and(|m| m.permissions().readonly());
        if cfg!(windows) && read_only {
            std::io::Error::new(
                e.kind(),
                format!("it is read-only, so it cannot be replaced; the old file is kept ({e})"),
            )
        } else if held_open(&e) && path.exists() {
            std::io::Error::new(
                e.kind(),
                format!(
                    "another program has it open, so it cannot be replaced \
                     (close it there and try again); the old file is kept ({e})"
                ),
            )
        } else {
            e
        }
    })
}

/// Whether a failed rename means the target is held open by another
/// program: Windows' access denied (5), sharing (32) and lock (33)
/// violations. A rename over an open file never fails on Unix.
fn held_open(e: &std::io::Error) -> bool {
    cfg!(windows) && matches!(e.raw_os_error(), Some(5 | 32 | 33))
}

impl Mesh {
    /// Parses a mesh from bytes and validates it; `path` names it in errors
    /// and anchors relative references (glTF buffers).
    pub fn from_bytes(bytes: &[u8], format: Format, path: &Path) -> Result<Mesh> {
        Mesh::from_bytes_noting(bytes, format, path, &mut Skipped::default())
    }

    /// [`Mesh::from_bytes`], counting what the reader does not keep.
    fn from_bytes_noting(
        bytes: &[u8],
        format: Format,
        path: &Path,
        skipped: &mut Skipped,
    ) -> Result<Mesh> {
        let mesh = crate::formats::parse(bytes, format, path, skipped)?;
        mesh.validate(path)?;
        Ok(mesh)
    }

    /// Encodes the mesh in `format` (a glTF's object named `mesh`).
    pub fn to_bytes(&self, format: Format) -> Result<Vec<u8>> {
        self.to_bytes_for(format, Path::new("<memory>"))
    }

    /// The bytes of the file `path`: a glTF's object is named after the
    /// file (`out/bunny.glb` makes `bunny` in Blender).
    fn to_bytes_for(&self, format: Format, path: &Path) -> Result<Vec<u8>> {
        self.validate(path)?;
        let name = path.file_stem().and_then(|s| s.to_str());
        let name = name.filter(|s| !s.is_empty() && *s != "<memory>");
        Ok(crate::formats::encode(self, format, name.unwrap_or("mesh")))
    }
}
