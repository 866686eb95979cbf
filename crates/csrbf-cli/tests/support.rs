use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh directory for one test, removed when dropped.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        let d = std::env::temp_dir().join(format!("csrbf-cli-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp dir");
        TempDir(d)
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    pub fn write(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).expect("write");
        p
    }

    /// Files in the directory (to check that nothing partial was left).
    pub fn files(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.0)
            .expect("dir")
            .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
            .collect();
        v.sort();
        v
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The models bundled in the repository: every test can use these.
pub fn bundled_dir() -> PathBuf {
    root().join("assets/models")
}

/// A real model by file name: the bundled copy, else the shared folder's.
/// A test that names a model neither holds fails saying so (never skips).
pub fn model(name: &str) -> PathBuf {
    let bundled = bundled_dir().join(name);
    if bundled.is_file() {
        return bundled;
    }
    let shared = root().join("../shared/models").join(name);
    assert!(
        shared.is_file(),
        "model {name} is neither bundled (assets/models) nor in ../shared/models"
    );
    shared
}

/// Every real model: the bundled ones, and those of `../shared/models` as an
/// extra when that folder is beside the checkout (said on standard error).
pub fn all_models() -> Vec<PathBuf> {
    let list = |dir: &Path| -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        v.retain(|p| csrbf_mesh::Format::from_path(p).is_ok());
        v.sort();
        v
    };
    let mut models = list(&bundled_dir());
    let shared = root().join("../shared/models");
    if shared.is_dir() {
        let extra: Vec<PathBuf> = list(&shared)
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

pub fn csrbf(args: &[&str]) -> Output {
    command().args(args).output().expect("run csrbf")
}

/// The `csrbf` under test: the one built with these tests or, when
/// `CSRBF_TEST_EXE` names another, that one run by `CSRBF_TEST_RUNNER` (how
/// scripts/test_windows.py runs the bad-input tests on `csrbf.exe` under Wine).
pub fn command() -> Command {
    match std::env::var_os("CSRBF_TEST_EXE") {
        Some(exe) => {
            let runner = std::env::var_os("CSRBF_TEST_RUNNER").unwrap_or_else(|| "wine".into());
            let mut c = Command::new(runner);
            c.arg(exe);
            c
        }
        None => Command::new(env!("CARGO_BIN_EXE_csrbf")),
    }
}

pub fn arg(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// Runs and expects success, returning standard output.
#[track_caller]
pub fn ok(args: &[&str]) -> String {
    let out = csrbf(args);
    assert!(
        out.status.success(),
        "csrbf {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs and expects failure with a message containing every `want`;
/// checks there was no panic.
#[track_caller]
pub fn fails(args: &[&str], want: &[&str]) -> String {
    let out = csrbf(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        !out.status.success(),
        "csrbf {args:?} succeeded; stderr: {err}"
    );
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "csrbf {args:?} panicked: {err}");
    for w in want {
        assert!(
            err.contains(w),
            "csrbf {args:?}: {err:?} does not contain {w:?}"
        );
    }
    err
}

/// A control file for a mesh: starts on vertices spread over the mesh, the
/// first few moved by a tenth of the diagonal, with R a quarter of it.
pub fn controls_for(mesh: &Path, kernel: &str, poly: &str) -> String {
    let m = csrbf_mesh::read(mesh).expect("mesh");
    let diag = m.diagonal() as f64;
    let n = m.positions.len();
    let k = 12.min(n);
    let mut controls = Vec::new();
    let mut used = Vec::new();
    for i in 0..k {
        let v = m.positions[i * n / k].as_dvec3();
        if used
            .iter()
            .any(|u: &glam::DVec3| u.distance(v) < 1e-6 * diag)
        {
            continue;
        }
        used.push(v);
        let d = if i < 3 {
            glam::DVec3::new(0.0, 0.1 * diag, 0.0)
        } else {
            glam::DVec3::ZERO
        };
        controls.push(serde_json::json!({ "from": v.to_array(), "to": (v + d).to_array() }));
    }
    serde_json::json!({ "kernel": kernel, "radius": 0.25 * diag, "polynomial": poly, "controls": controls }).to_string()
}
