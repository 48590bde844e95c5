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

/// A folder of the test's own (`tag` and this process's id) under the system's temporary one.
pub fn scratch_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("patrol-plan-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A file `name` holding `text` in [`scratch_dir`]`(tag)`.
pub fn scratch_file(tag: &str, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
    let file = scratch_dir(tag).join(name);
    std::fs::write(&file, text).unwrap();
    file
}
