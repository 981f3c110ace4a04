//! The checkpoint container every trainer writes: the magic `LUCIDCKP`, a little-endian `u32`
//! format version, then length-prefixed (`u64`) sections, the first a JSON header whose
//! `kind` names the model. Written to a temporary name and renamed, so a crash never leaves
//! a torn file under the real name.

use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"LUCIDCKP";
const VERSION: u32 = 1;

/// Why a checkpoint could not be read or written; each message names the file.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// The OS refused.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a checkpoint, or one of another kind or version, or damaged.
    #[error("{}: {reason}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// Whether `path` starts like a Lucid checkpoint (any kind).
pub fn is_checkpoint(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path).and_then(|mut f| f.read_exact(&mut magic)).is_ok() && &magic == MAGIC
}

/// Peeks at a checkpoint's kind without loading it: reads the preamble and the JSON header
/// only (commands that dispatch on the kind then load the file once, not twice).
pub fn read_kind(path: &Path) -> Result<String, CheckpointError> {
    use std::io::Read;
    let io = |source| CheckpointError::Io { path: path.into(), source };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    let mut preamble = Vec::with_capacity(20);
    (&mut file).take(20).read_to_end(&mut preamble).map_err(io)?;
    check_preamble(path, &preamble)?;
    if preamble.len() < 20 {
        return Err(invalid(path, "truncated (no header)"));
    }
    let len = u64::from_le_bytes(preamble[12..20].try_into().expect("8 bytes"));
    if len > size.saturating_sub(20) {
        return Err(invalid(
            path,
            format!("truncated (section 0 needs {len} bytes, {} left)", size.saturating_sub(20)),
        ));
    }
    let mut head = Vec::with_capacity(len as usize);
    file.take(len).read_to_end(&mut head).map_err(io)?;
    let header: serde_json::Value =
        serde_json::from_slice(&head).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    Ok(header.get("kind").and_then(|k| k.as_str()).unwrap_or("unknown").to_string())
}

/// Checks the magic and the format version at the start of `bytes`.
fn check_preamble(path: &Path, bytes: &[u8]) -> Result<(), CheckpointError> {
    if bytes.len() < 12 || &bytes[..8] != MAGIC {
        return Err(invalid(path, "not a Lucid checkpoint (bad magic)"));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(invalid(path, format!("checkpoint format version {version}, this build reads {VERSION}")));
    }
    Ok(())
}

/// An [`CheckpointError::Invalid`] for `path`.
pub fn invalid(path: &Path, reason: impl Into<String>) -> CheckpointError {
    CheckpointError::Invalid { path: path.into(), reason: reason.into() }
}

/// Splits a checkpoint into its JSON header and the remaining sections.
pub fn parse<'a, H: serde::de::DeserializeOwned>(
    path: &Path,
    bytes: &'a [u8],
) -> Result<(H, Vec<&'a [u8]>), CheckpointError> {
    check_preamble(path, bytes)?;
    let mut rest = &bytes[12..];
    let mut sections = Vec::new();
    while !rest.is_empty() {
        if rest.len() < 8 {
            return Err(invalid(path, "truncated (a section length is cut off)"));
        }
        let len = u64::from_le_bytes(rest[..8].try_into().expect("8 bytes")) as usize;
        if rest.len() - 8 < len {
            return Err(invalid(
                path,
                format!("truncated (section {} needs {len} bytes, {} left)", sections.len(), rest.len() - 8),
            ));
        }
        sections.push(&rest[8..8 + len]);
        rest = &rest[8 + len..];
    }
    let Some((head, tail)) = sections.split_first() else {
        return Err(invalid(path, "truncated (no header)"));
    };
    let header = serde_json::from_slice(head).map_err(|e| invalid(path, format!("malformed header: {e}")))?;
    Ok((header, tail.to_vec()))
}

/// Reads a checkpoint of `kind`: its JSON header and the remaining sections.
pub fn read_kind_sections(path: &Path, kind: &str) -> Result<(serde_json::Value, Vec<Vec<u8>>), CheckpointError> {
    let bytes = std::fs::read(path).map_err(|source| CheckpointError::Io { path: path.into(), source })?;
    let (value, sections): (serde_json::Value, _) = parse(path, &bytes)?;
    let found = value.get("kind").and_then(|k| k.as_str()).unwrap_or("unknown");
    if found != kind {
        return Err(invalid(path, format!("the checkpoint holds a '{found}' model, expected '{kind}'")));
    }
    let sections = sections.into_iter().map(<[u8]>::to_vec).collect();
    Ok((value, sections))
}

/// Writes `sections` (the JSON header first) atomically to `path`.
pub fn write_sections(path: &Path, sections: &[&[u8]]) -> Result<(), CheckpointError> {
    let tmp = path.with_file_name(format!(
        ".{}.tmp-{}",
        path.file_name().and_then(|n| n.to_str()).unwrap_or("checkpoint"),
        std::process::id()
    ));
    let write = || -> std::io::Result<()> {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        f.write_all(MAGIC)?;
        f.write_all(&VERSION.to_le_bytes())?;
        for section in sections {
            f.write_all(&(section.len() as u64).to_le_bytes())?;
            f.write_all(section)?;
        }
        f.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    };
    write().map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        CheckpointError::Io { path: path.into(), source }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kind comes from the header alone; damaged files still say what is wrong.
    #[test]
    fn read_kind_reads_the_header_and_names_damage() {
        let dir = std::env::temp_dir().join(format!("lucid-ckpt-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.lucid");
        write_sections(&path, &[br#"{"kind": "splat"}"#, &[7u8; 1000]]).unwrap();
        assert_eq!(read_kind(&path).unwrap(), "splat");
        let bytes = std::fs::read(&path).unwrap();
        // Cut inside the header: truncated; cut after it: the kind is still known.
        std::fs::write(dir.join("b.lucid"), &bytes[..25]).unwrap();
        assert!(read_kind(&dir.join("b.lucid")).unwrap_err().to_string().contains("truncated"));
        std::fs::write(dir.join("c.lucid"), &bytes[..60]).unwrap();
        assert_eq!(read_kind(&dir.join("c.lucid")).unwrap(), "splat");
        assert!(read_kind_sections(&dir.join("c.lucid"), "splat").unwrap_err().to_string().contains("truncated"));
        std::fs::write(dir.join("d.lucid"), b"\x89PNG\r\n\x1a\n....").unwrap();
        assert!(read_kind(&dir.join("d.lucid")).unwrap_err().to_string().contains("not a Lucid checkpoint"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
