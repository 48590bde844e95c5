//! What every patrol-planner binary reads from a user's file passes here first, so that no file
//! can hang a binary or exhaust its memory: [`read_file`] reads a regular file of bounded size
//! (opened without blocking; a FIFO, a device or a directory is refused unread), and
//! [`yaml::check`] refuses YAML text nested deeper than any parameter, map or route file needs,
//! before a parser spends minutes on it. The planner's loaders (planner-io) and the chassis bridge's parameter file
//! (ros-edge) both read through it.

pub mod yaml;

#[cfg(feature = "fs")]
use std::io::{self, Read};
#[cfg(feature = "fs")]
use std::path::Path;

/// The whole file at `path`, refused with [`io::ErrorKind::InvalidInput`] when it is not a
/// regular file or holds more than `max_bytes`.
///
/// The file is opened without blocking (`O_NONBLOCK`): opening a FIFO otherwise waits for a
/// writer, which would hang the binary for good. What was opened is then looked at (so a path
/// swapped for a FIFO between a look and the open changes nothing), and the read stops one
/// byte past the cap, since a file can grow while it is read.
#[cfg(feature = "fs")]
pub fn read_file(path: &Path, max_bytes: u64) -> io::Result<Vec<u8>> {
    use std::os::unix::fs::OpenOptionsExt;
    let refuse = |what: String| io::Error::new(io::ErrorKind::InvalidInput, what);
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(refuse("not a regular file".into()));
    }
    if meta.len() > max_bytes {
        return Err(refuse(format!(
            "{} bytes, more than the {max_bytes} read",
            meta.len()
        )));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(max_bytes + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(refuse(format!("more than the {max_bytes} bytes read")));
    }
    Ok(bytes)
}

#[cfg(all(test, feature = "fs"))]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("input-guard-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn a_small_regular_file_is_read_whole() {
        let path = scratch("small.yaml");
        std::fs::write(&path, b"a: 1\n").unwrap();
        assert_eq!(read_file(&path, 5).unwrap(), b"a: 1\n");
        let err = read_file(&path, 4).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::InvalidInput);
        assert!(err.to_string().contains("more than the 4"), "{err}");
    }

    /// A FIFO is refused at once: opening it would wait for a writer for ever.
    #[test]
    fn a_fifo_a_device_and_a_directory_are_refused_without_waiting() {
        let fifo = scratch("fifo.yaml");
        let _ = std::fs::remove_file(&fifo);
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        assert!(made.is_ok_and(|s| s.success()), "mkfifo");
        for path in [
            fifo.as_path(),
            Path::new("/dev/zero"),
            fifo.parent().unwrap(),
        ] {
            let err = read_file(path, 1 << 20).unwrap_err();
            assert_eq!(
                err.kind(),
                io::ErrorKind::InvalidInput,
                "{}",
                path.display()
            );
            assert!(err.to_string().contains("not a regular file"), "{err}");
        }
    }

    #[test]
    fn a_missing_file_says_so() {
        let err = read_file(&scratch("missing.yaml"), 10).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::NotFound);
    }
}
