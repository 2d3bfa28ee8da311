//! Helpers of the integration tests: running the `diamonds` binary, temporary folders, fixtures, the
//! shared volumes, field data.
#![allow(dead_code)]

use diamonds_cli::Array;
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};

/// A folder under the system's temporary folder, removed on drop.
pub struct TempDir(PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("diamonds-cli-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("create a temporary folder");
        Self(dir)
    }

    pub fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// What a run of `diamonds` did.
#[derive(Debug)]
pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

impl Run {
    /// Asserts success and returns stdout.
    pub fn ok(self) -> String {
        assert_eq!(self.code, 0, "diamonds failed: {self:#?}");
        self.stdout
    }

    /// Asserts a clean user error (exit 2, `error: …`, no panic) and returns the message.
    pub fn user_error(self) -> String {
        assert_eq!(self.code, 2, "expected exit code 2: {self:#?}");
        assert!(
            self.stderr.starts_with("error: "),
            "expected 'error: …' on stderr: {self:#?}"
        );
        for bad in ["panicked", "RUST_BACKTRACE", "internal error"] {
            assert!(!self.stderr.contains(bad), "{bad} in stderr: {self:#?}");
        }
        self.stderr
    }
}

/// Runs `diamonds` with `args`.
pub fn diamonds<I, S>(args: I) -> Run
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let out = Command::new(env!("CARGO_BIN_EXE_diamonds"))
        .args(args)
        .output()
        .expect("run diamonds");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// A reader fixture of the vtkxml crate (written by VTK itself, see
/// ../vtkxml/tests/fixtures/make_fixtures.py).
pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../vtkxml/tests/fixtures")
        .join(name)
}

/// `p` as `&str` for argument lists.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// The single value of the field-data array `name`.
pub fn field_value(field_data: &[Array], name: &str) -> f64 {
    let a = field_data
        .iter()
        .find(|a| a.name == name)
        .unwrap_or_else(|| panic!("no field data {name}: {field_data:?}"));
    assert_eq!(a.data.len(), 1, "{name}");
    a.value(0)
}

/// `../shared` beside the checkout.
pub fn shared_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

/// Whether a missing `../shared` must fail the tests instead of skipping them: under CI (`CI=true`,
/// as `.ci/run` sets) or with `DIAMONDS_REQUIRE_SHARED=1`.
fn shared_required() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true" || v == "1")
        || std::env::var("DIAMONDS_REQUIRE_SHARED").is_ok_and(|v| v == "1")
}

/// Prints "skipped: {why}", or panics with it when the shared data is required ([`shared_required`]).
fn skip(why: String) {
    assert!(
        !shared_required(),
        "{why}, and the shared data is required here (CI=true or DIAMONDS_REQUIRE_SHARED=1)"
    );
    println!("skipped: {why}");
}

/// `relative` under `../shared`, or `None` (with the skip message printed, or a failure when the
/// shared data is required) when absent.
pub fn shared_file(relative: &str) -> Option<PathBuf> {
    let path = shared_dir().join(relative);
    if path.exists() {
        return Some(path);
    }
    skip(format!(
        "../shared/{relative} not found (looked for {})",
        path.display()
    ));
    None
}

/// The `.vti` files of the shared volumes, or `None` (with the skip message printed, or a failure
/// when the shared data is required) when absent.
pub fn shared_volumes() -> Option<Vec<PathBuf>> {
    let dir = shared_file("data/volumes")?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("read ../shared/data/volumes")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "vti"))
        .collect();
    files.sort();
    if files.is_empty() {
        skip(format!("no .vti in {}", dir.display()));
        return None;
    }
    Some(files)
}

/// `name` in the shared volumes, or `None` (with the skip message printed, or a failure when the
/// shared data is required) when absent.
pub fn shared_volume(name: &str) -> Option<PathBuf> {
    let files = shared_volumes()?;
    let found = files.into_iter().find(|p| p.ends_with(name));
    if found.is_none() {
        skip(format!("{name} not found in ../shared/data/volumes"));
    }
    found
}
