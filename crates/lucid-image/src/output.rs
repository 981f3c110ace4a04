//! Output folders that one process owns at a time, and small text outputs written atomically.
//!
//! `train`, `gen` and `render` take an advisory lock ([`OutputLock`]) on what they write before
//! they write anything: a second process aimed at the same output fails at once with a message
//! naming it and the PID of the holder, instead of both "succeeding" with interleaved files.
//! The lock is the operating system's (`flock` on Unix, `LockFileEx` on Windows, through
//! `std::fs::File::try_lock`), so it is released when the holder exits, even when killed.

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use crate::ImageError;

/// Name of the lock file inside a locked folder.
pub const LOCK_FILE: &str = ".lucid.lock";

/// Whether a file name is one of [`OutputLock`]'s lock files (`.lucid.lock`, `.<name>.lock`),
/// which a killed process leaves behind.
pub fn is_lock_file(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(".lock")
}

/// An exclusive advisory lock, held until dropped.
#[derive(Debug)]
pub struct OutputLock {
    _file: File,
    path: PathBuf,
}

/// Why an output could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds it.
    #[error("{}: in use by another lucid process{}; wait for it to finish or choose another output", what.display(), holder.map(|p| format!(" (PID {p})")).unwrap_or_default())]
    Held {
        /// The folder or file that is locked.
        what: PathBuf,
        /// The holder's PID, as it wrote it into the lock file.
        holder: Option<u32>,
    },
    /// The lock file could not be made.
    #[error("{}: {source}", path.display())]
    Io {
        /// The lock file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl OutputLock {
    /// Locks folder `dir` (which must exist) through `dir/.lucid.lock`.
    pub fn folder(dir: &Path) -> Result<Self, LockError> {
        Self::acquire(dir.join(LOCK_FILE), dir)
    }

    /// Locks the single output file `file` through `.<name>.lock` beside it (its folder must
    /// exist), so that writers of other files in the same folder do not wait on each other.
    pub fn file(file: &Path) -> Result<Self, LockError> {
        let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        Self::acquire(file.with_file_name(format!(".{name}.lock")), file)
    }

    fn acquire(path: PathBuf, what: &Path) -> Result<Self, LockError> {
        let io = |source| LockError::Io { path: path.clone(), source };
        loop {
            // Not truncated on open: the holder's PID must survive a failed attempt to read it.
            let mut file =
                OpenOptions::new().read(true).write(true).create(true).truncate(false).open(&path).map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let holder = file.read_to_string(&mut text).ok().and_then(|_| text.trim().parse().ok());
                    return Err(LockError::Held { what: what.to_path_buf(), holder });
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
            }
            // The last holder removes the file as it lets go; a file opened just before that
            // is no longer the one at `path`, and its lock guards nothing: open again.
            if !same_file(&file, &path) {
                continue;
            }
            file.set_len(0).map_err(io)?;
            file.rewind().map_err(io)?;
            write!(file, "{}", std::process::id()).and_then(|()| file.flush()).map_err(io)?;
            return Ok(Self { _file: file, path });
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    /// Removes the lock file while still holding it, so that outputs keep no trace of the
    /// lock (a dataset stays byte-identical whoever made it).
    fn drop(&mut self) {
        if cfg!(unix) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Whether `file` is the file now at `path` (always true where this cannot be told).
fn same_file(file: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (file.metadata(), std::fs::metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = (file, path);
        true
    }
}

/// Writes a text file atomically (a temporary name in the same folder, then a rename).
pub fn write_text(path: &Path, text: &str) -> Result<(), ImageError> {
    crate::write_atomically(path, |w| w.write_all(text.as_bytes()).map_err(|e| ImageError::io(path, e)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A second lock on the same folder fails naming it and this process; dropping the first
    /// frees it. (Locks of one file through two handles conflict within one process too.)
    #[test]
    fn a_second_lock_fails_with_the_holder_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let first = OutputLock::folder(dir.path()).unwrap();
        let err = OutputLock::folder(dir.path()).unwrap_err().to_string();
        assert!(err.contains(&dir.path().display().to_string()), "{err}");
        assert!(err.contains(&format!("PID {}", std::process::id())), "{err}");
        drop(first);
        let again = OutputLock::folder(dir.path()).unwrap();
        assert_eq!(std::fs::read_to_string(again.path()).unwrap(), std::process::id().to_string());
        let path = again.path().to_path_buf();
        drop(again);
        assert!(!path.exists(), "no trace of the lock left");

        let out = dir.path().join("a.exr");
        let _a = OutputLock::file(&out).unwrap();
        assert!(OutputLock::file(&out).is_err());
        assert!(OutputLock::file(&dir.path().join("b.exr")).is_ok());
    }
}
