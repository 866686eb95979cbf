//! Paths inside scene files. A scene names its meshes, textures and control
//! files relative to its own folder, written with `/` (the studio and the
//! demos write them so on every system); either separator is read, so a
//! scene written on Windows (`models\head.off`) opens on Linux and the other
//! way round.
//!
//! ```
//! use std::path::Path;
//! let p = csrbf_anim::path::resolve(Path::new("scenes"), r"..\models\head.off");
//! assert_eq!(p, Path::new("models").join("head.off"));
//! ```

use std::path::{Path, PathBuf};

/// The file a scene in the folder `dir` names as `named`: relative to `dir`,
/// or absolute. `\` separates parts like `/` on every system (a file name
/// holding a backslash cannot be named on Unix). A path with a drive letter
/// (`C:\models\head.off`) is absolute on Windows; elsewhere it names nothing
/// that exists, and the error that follows names it.
pub fn resolve(dir: &Path, named: &str) -> PathBuf {
    tidy(&dir.join(portable(named)))
}

/// `p` without `.` parts, and with `folder/..` taken out where `folder` is
/// a folder (or does not exist), so `saved/../x.json` reads `x.json`; after a
/// symbolic link `..` is the link target's parent, so it stays.
fn tidy(p: &Path) -> PathBuf {
    use std::path::Component;
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                let folder = matches!(out.components().next_back(), Some(Component::Normal(_)))
                    && !std::fs::symlink_metadata(&out).is_ok_and(|m| m.file_type().is_symlink());
                if folder {
                    out.pop();
                } else {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
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
        let want = Path::new("models").join("head.off");
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

    #[test]
    fn a_folder_and_its_parent_cancel_but_not_past_a_link_or_the_start() {
        let base = Path::new("scenes").join("saved");
        assert_eq!(
            resolve(&base, "../x.json"),
            Path::new("scenes").join("x.json")
        );
        assert_eq!(resolve(&base, "./a/./b.off"), base.join("a").join("b.off"));
        assert_eq!(
            resolve(Path::new(".."), "../m.off"),
            Path::new("..").join("..").join("m.off")
        );
        #[cfg(unix)]
        {
            let dir = std::env::temp_dir().join(format!("csrbf-path-{}", std::process::id()));
            let real = dir.join("deep").join("real");
            std::fs::create_dir_all(&real).expect("dirs");
            let link = dir.join("link");
            let _ = std::fs::remove_file(&link);
            std::os::unix::fs::symlink(&real, &link).expect("link");
            // link/.. is deep/, not dir/: the path keeps its "..".
            assert_eq!(resolve(&link, "../x.json"), link.join("..").join("x.json"));
            std::fs::remove_dir_all(&dir).ok();
        }
    }
}
