//! What the workspace's integration tests share: where the real models are.
//! The models bundled in the repository (`assets/models`) are always there;
//! those of `../shared/models`, beside the checkout, are used as an extra
//! when that folder exists. Paths are found from this crate's own folder,
//! so they name the checkout being tested whatever the target directory.
//!
//! Scratch folders ([`scratch`]) are named by the checkout as well as the
//! test, so two checkouts sharing one target directory (`CARGO_TARGET_DIR`)
//! never read each other's files.
//!
//! ```
//! let head = csrbf_testkit::model("cgal_head.off");
//! assert!(head.is_file());
//! assert!(csrbf_testkit::all_models().contains(&head));
//! ```

#![warn(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

/// The root of the checkout.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The models bundled in the repository: every test can use these.
pub fn bundled_dir() -> PathBuf {
    root().join("assets/models")
}

/// The folder of extra models beside the checkout (may be absent).
pub fn shared_dir() -> PathBuf {
    root().join("../shared/models")
}

/// A real model by file name: the bundled copy, else the shared folder's.
/// A test that names a model neither holds fails saying so (never skips).
pub fn model(name: &str) -> PathBuf {
    let bundled = bundled_dir().join(name);
    if bundled.is_file() {
        return bundled;
    }
    let shared = shared_dir().join(name);
    assert!(
        shared.is_file(),
        "model {name} is neither bundled (assets/models) nor in ../shared/models"
    );
    shared
}

/// The mesh files of a folder (those with an ending the mesh crate reads),
/// sorted; none when the folder cannot be read.
pub fn meshes_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    v.retain(|p| csrbf_mesh::Format::from_path(p).is_ok());
    v.sort();
    v
}

/// Every real model: the bundled ones, and those of `../shared/models` not
/// bundled, as an extra when that folder is beside the checkout (said on
/// standard error either way).
pub fn all_models() -> Vec<PathBuf> {
    let mut models = meshes_in(&bundled_dir());
    let shared = shared_dir();
    if shared.is_dir() {
        let extra: Vec<PathBuf> = meshes_in(&shared)
            .into_iter()
            .filter(|p| !models.iter().any(|m| m.file_name() == p.file_name()))
            .collect();
        eprintln!(
            "also using {} models from {}",
            extra.len(),
            shared.display()
        );
        models.extend(extra);
    } else {
        eprintln!("{} not found: the bundled models only", shared.display());
    }
    models
}

/// A fresh, empty folder for one test under `target_tmp` (pass
/// `env!("CARGO_TARGET_TMPDIR")`): `NAME-KEY`, where KEY names this checkout.
/// A target directory shared by two checkouts then holds two folders, and a
/// test never reads what the other checkout's run of it wrote there (issue
/// 19: a scene saved by one run named the other checkout's meshes).
pub fn scratch(target_tmp: &str, name: &str) -> PathBuf {
    let d = Path::new(target_tmp).join(format!("{name}-{}", checkout_key(&root())));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("a scratch folder in the target directory");
    d
}

/// A short name of the checkout at `root`: a hash of its full path.
pub fn checkout_key(root: &Path) -> String {
    use std::hash::{Hash, Hasher};
    let full = std::fs::canonicalize(root).unwrap_or_else(|_| root.to_path_buf());
    let mut h = std::collections::hash_map::DefaultHasher::new();
    full.hash(&mut h);
    format!("{:08x}", h.finish() as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bundled_models_are_listed_first_and_sorted() {
        let all = all_models();
        let bundled = meshes_in(&bundled_dir());
        assert!(bundled.len() >= 7, "{bundled:?}");
        assert_eq!(&all[..bundled.len()], &bundled[..]);
        let mut sorted = bundled.clone();
        sorted.sort();
        assert_eq!(bundled, sorted);
        // No shared model repeats a bundled one's name.
        for extra in &all[bundled.len()..] {
            assert!(!bundled.iter().any(|b| b.file_name() == extra.file_name()));
        }
    }

    #[test]
    fn two_checkouts_sharing_a_target_directory_get_their_own_scratch_folders() {
        let tmp = std::env::temp_dir().join(format!("csrbf-testkit-{}", std::process::id()));
        let (a, b) = (tmp.join("a/checkout"), tmp.join("b/checkout"));
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        assert_ne!(checkout_key(&a), checkout_key(&b));
        assert_eq!(checkout_key(&a), checkout_key(&a.join("../checkout")));
        let d = scratch(tmp.to_str().unwrap(), "t");
        std::fs::write(d.join("f"), "x").unwrap();
        // Fresh each time: what an earlier run left is gone.
        assert_eq!(scratch(tmp.to_str().unwrap(), "t"), d);
        assert!(!d.join("f").exists());
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn a_model_is_found_by_name_and_a_missing_one_fails_saying_so() {
        assert!(model("cgal_head.off").is_file());
        let missing = std::panic::catch_unwind(|| model("no-such-model.off"));
        assert!(missing.is_err());
    }
}
