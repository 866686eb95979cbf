//! Reading and writing files: format by extension, validation on read,
//! whole-or-nothing writes.

use std::io::Write;
use std::path::{Path, PathBuf};

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
/// error: a text format with no line break at its end may have been cut off.
pub fn load(path: &Path) -> Result<Loaded> {
    let format = Format::from_path(path)?;
    let bytes = std::fs::read(path).map_err(|source| MeshError::Io {
        path: path.to_owned(),
        source,
    })?;
    let mesh = Mesh::from_bytes(&bytes, format, path)?;
    let mut warnings = Vec::new();
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
///
/// An OBJ with material parts names a material library beside it: the one
/// it was read with when that file is there, else `STEM.mtl` written with
/// it (with its textures), unless a file of that name that csrbf did not
/// write is in the way; then it names none. Never a library that is not there.
pub fn write(path: &Path, mesh: &Mesh) -> Result<()> {
    let format = Format::from_path(path)?;
    if format == Format::Obj {
        mesh.validate(path)?;
        let library = write_obj_library(path, mesh)?;
        return write_atomic(path, &crate::formats::obj::encode(mesh, library.as_deref()));
    }
    let bytes = mesh.to_bytes_for(format, path)?;
    write_atomic(path, &bytes)
}

/// Writes the material library an OBJ at `path` names, if it needs one;
/// returns the name for its `mtllib` line.
fn write_obj_library(path: &Path, mesh: &Mesh) -> Result<Option<String>> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let stem = path
        .file_stem()
        .map_or("mesh".into(), |s| s.to_string_lossy());
    let Some(lib) = crate::formats::obj::library(mesh, &stem) else {
        return Ok(None);
    };
    if let Some(kept) = &mesh.material_library
        && dir.join(kept).is_file()
    {
        return Ok(Some(kept.clone()));
    }
    let name = format!("{stem}.mtl");
    let target = dir.join(&name);
    let ours = |p: &Path| {
        std::fs::read(p).map_or(true, |b| {
            b.starts_with(crate::formats::obj::WRITTEN_BY.as_bytes())
        })
    };
    if target.exists() && !ours(&target) {
        return Ok(None);
    }
    for (file, bytes) in &lib.textures {
        write_atomic(&dir.join(file), bytes)?;
    }
    write_atomic(&target, lib.text.as_bytes())?;
    Ok(Some(name))
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
        replace(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    untrack_temp(&tmp);
    result.map_err(io)
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
        let mesh = crate::formats::parse(bytes, format, path)?;
        mesh.validate(path)?;
        Ok(mesh)
    }

    /// Encodes the mesh in `format`.
    pub fn to_bytes(&self, format: Format) -> Result<Vec<u8>> {
        self.to_bytes_for(format, Path::new("<memory>"))
    }

    fn to_bytes_for(&self, format: Format, path: &Path) -> Result<Vec<u8>> {
        self.validate(path)?;
        Ok(crate::formats::encode(self, format))
    }
}
