//! What the CLI's integration tests share: running the binary as a user does, and the paths of
//! the shared maps and the repository's own files.
#![allow(dead_code)] // each test binary uses its own part

use std::path::PathBuf;
use std::process::Command;

/// `patrol-plan ARGS`: (success, stdout, stderr).
pub fn patrol_plan(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_patrol-plan"))
        .args(args)
        .output()
        .expect("runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// A file of ../shared/maps (the tests need ../shared beside the repository).
pub fn shared(p: &str) -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/maps");
    assert!(
        root.is_dir(),
        "{} is missing: the tests need ../shared beside the repository",
        root.display()
    );
    root.join(p)
}

/// A file of this repository.
pub fn repo(p: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(p)
        .to_str()
        .unwrap()
        .to_string()
}
