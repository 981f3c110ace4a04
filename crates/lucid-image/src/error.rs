//! The error type of image reading and writing: every variant names the file.

use std::path::{Path, PathBuf};

/// Why an image could not be read or written. The `Display` form is one line that names
/// the file and the problem, ready to show to a user.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The operating system refused (missing file, permissions, disk full…).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The extension names no format we know.
    #[error(
        "{}: unsupported image format {ext:?} (supported: .exr, .pfm, .hdr/.rgbe, .png, .jpg/.jpeg)",
        path.display()
    )]
    UnsupportedFormat {
        /// The file involved.
        path: PathBuf,
        /// Its extension, as written.
        ext: String,
    },
    /// The file exists but its content is not a valid file of its format.
    #[error("{}: malformed {format} file: {reason}", path.display())]
    Malformed {
        /// The file involved.
        path: PathBuf,
        /// Format name, e.g. "PFM".
        format: &'static str,
        /// What was wrong.
        reason: String,
    },
    /// Writing failed for a reason other than I/O (encoder error, unrepresentable data).
    #[error("{}: cannot write {format}: {reason}", path.display())]
    Encode {
        /// The file involved.
        path: PathBuf,
        /// Format name.
        format: &'static str,
        /// What went wrong.
        reason: String,
    },
    /// The output folder cannot be written (another's files, an input inside, in use).
    #[error(transparent)]
    Folder(Box<crate::owned_folder::FolderError>),
}

impl From<crate::owned_folder::FolderError> for ImageError {
    fn from(e: crate::owned_folder::FolderError) -> Self {
        Self::Folder(Box::new(e))
    }
}

impl ImageError {
    /// An I/O failure on `path` (for callers of [`crate::write_atomically`] writing their own bytes).
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), source }
    }

    pub(crate) fn malformed(path: &Path, format: &'static str, reason: impl Into<String>) -> Self {
        Self::Malformed { path: path.to_path_buf(), format, reason: reason.into() }
    }

    pub(crate) fn encode(path: &Path, format: &'static str, reason: impl ToString) -> Self {
        Self::Encode { path: path.to_path_buf(), format, reason: reason.to_string() }
    }
}
