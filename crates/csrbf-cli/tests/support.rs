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

// Where the real models are: one copy for every crate's tests.
pub use csrbf_testkit::{all_models, model, root};

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
        "csrbf {args:?} failed ({}): stderr {:?}, stdout {:?}",
        out.status,
        String::from_utf8_lossy(&out.stderr),
        String::from_utf8_lossy(&out.stdout)
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

/// `deform --mesh MESH --controls CONTROLS --out OUT`.
pub fn deform_args<'a>(mesh: &'a Path, controls: &'a Path, out: &'a Path) -> Vec<&'a str> {
    vec![
        "deform",
        "--mesh",
        arg(mesh),
        "--controls",
        arg(controls),
        "--out",
        arg(out),
    ]
}

/// `csrbf deform -q --json` of `mesh` by `controls` into `out`, with `extra`
/// flags; its JSON figures.
#[track_caller]
pub fn deform_json(mesh: &Path, controls: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = deform_args(mesh, controls, out);
    args.extend_from_slice(&["-q", "--json"]);
    args.extend_from_slice(extra);
    serde_json::from_str(&ok(&args)).expect("deform --json")
}
