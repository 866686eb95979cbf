//! Paths inside scene files. A scene names its meshes, textures and control
//! files relative to its own folder, written with `/` (the studio and the
//! demos write them so on every system); either separator is read, so a
//! scene written on Windows (`models\head.off`) opens on Linux and the other
//! way round.
//!
//! ```
//! use std::path::Path;
//! let p = csrbf_anim::path::resolve(Path::new("scenes"), r"..\models\head.off");
//! assert_eq!(p, Path::new("scenes").join("..").join("models").join("head.off"));
//! ```

use std::path::{Path, PathBuf};

/// The file a scene in the folder `dir` names as `named`: relative to `dir`,
/// or absolute. `\` separates parts like `/` on every system (a file name
/// holding a backslash cannot be named on Unix). A path with a drive letter
/// (`C:\models\head.off`) is absolute on Windows; elsewhere it names nothing
/// that exists, and the error that follows names it.
pub fn resolve(dir: &Path, named: &str) -> PathBuf {
    dir.join(portable(named))
}

/// `named` with its parts split at either separator, as this system's path.
pub fn portable(named: &str) -> PathBuf {
    if cfg!(windows) {
        PathBuf::from(named)
    } else {
        PathBuf::from(named.replace('\\', "/"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn either_separator_names_the_same_file() {
        let dir = Path::new("base");
        let want = dir.join("..").join("models").join("head.off");
        for named in [
            "../models/head.off",
            r"..\models\head.off",
            r"../models\head.off",
        ] {
            assert_eq!(resolve(dir, named), want, "{named}");
        }
        assert_eq!(resolve(dir, "head.off"), dir.join("head.off"));
    }

    #[test]
    fn absolute_paths_stay_absolute() {
        let abs = std::env::temp_dir().join("x.off");
        let named = abs.to_str().expect("utf-8");
        assert_eq!(resolve(Path::new("base"), named), abs);
    }

    #[test]
    fn a_drive_letter_path_is_absolute_on_windows_only() {
        let p = resolve(Path::new("base"), r"C:\models\head.off");
        assert_eq!(p.is_absolute(), cfg!(windows), "{}", p.display());
        if !cfg!(windows) {
            assert_eq!(p, Path::new("base/C:/models/head.off"));
        }
    }
}
