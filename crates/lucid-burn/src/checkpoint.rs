//! The checkpoint container every trainer writes: the magic `LUCIDCKP`, a little-endian `u32`
//! format version, a `u32` section count, the length-prefixed (`u64`) sections, the first a
//! JSON header whose `kind` names the model, and a CRC-32 of everything before it, so a
//! damaged file (a flipped byte, a cut, bytes appended) is refused instead of loading as a
//! different model. Written to a temporary name and renamed, so a crash never leaves a torn
//! file under the real name. Version 1 files (no count, no checksum) are still read.

use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"LUCIDCKP";
const VERSION: u32 = 2;

/// The version without section count and checksum, still read.
const VERSION_1: u32 = 1;

/// Bytes before the first section: magic, version and (from version 2) the section count.
fn preamble_len(version: u32) -> usize {
    if version == VERSION_1 { 12 } else { 16 }
}

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
    let header = read_header(path)?;
    Ok(header.get("kind").and_then(|k| k.as_str()).unwrap_or("unknown").to_string())
}

/// A checkpoint's JSON header (kind, configuration, steps taken, training seconds, …) without
/// reading its tensors.
pub fn read_header(path: &Path) -> Result<serde_json::Value, CheckpointError> {
    use std::io::Read;
    let io = |source| CheckpointError::Io { path: path.into(), source };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    let mut preamble = Vec::with_capacity(16);
    (&mut file).take(16).read_to_end(&mut preamble).map_err(io)?;
    let start = preamble_len(check_preamble(path, &preamble)?) as u64;
    use std::io::Seek;
    file.seek(std::io::SeekFrom::Start(start)).map_err(io)?;
    let mut len = [0u8; 8];
    file.read_exact(&mut len).map_err(|_| invalid(path, "truncated (no header)"))?;
    let len = u64::from_le_bytes(len);
    let left = size.saturating_sub(start + 8);
    if len > left {
        return Err(invalid(path, format!("truncated (section 0 needs {len} bytes, {left} left)")));
    }
    let mut head = Vec::with_capacity(len as usize);
    file.take(len).read_to_end(&mut head).map_err(io)?;
    serde_json::from_slice(&head).map_err(|e| invalid(path, format!("malformed header: {e}")))
}

/// Checks the magic and the format version at the start of `bytes`; returns the version.
fn check_preamble(path: &Path, bytes: &[u8]) -> Result<u32, CheckpointError> {
    if bytes.len() < 12 || &bytes[..8] != MAGIC {
        return Err(invalid(path, "not a Lucid checkpoint (bad magic)"));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != VERSION && version != VERSION_1 {
        return Err(invalid(
            path,
            format!("checkpoint format version {version}, this build reads {VERSION_1} and {VERSION}"),
        ));
    }
    if bytes.len() < preamble_len(version) {
        return Err(invalid(path, "truncated (no section count)"));
    }
    Ok(version)
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
    let version = check_preamble(path, bytes)?;
    let mut rest = &bytes[preamble_len(version)..];
    // Version 1 has no count: its sections run to the end of the file.
    let count = (version != VERSION_1).then(|| u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize);
    let mut sections = Vec::new();
    while count.map_or(!rest.is_empty(), |c| sections.len() < c) {
        if rest.len() < 8 {
            return Err(invalid(path, "truncated (a section length is cut off)"));
        }
        let len = u64::from_le_bytes(rest[..8].try_into().expect("8 bytes"));
        let left = rest.len() - 8;
        if (left as u64) < len {
            // No checkpoint section reaches a terabyte: such a length is damage, not a cut.
            let reason = if len > 1 << 40 {
                format!("damaged: section {} claims {len} bytes, the file has {}", sections.len(), bytes.len())
            } else {
                format!("truncated (section {} needs {len} bytes, {left} left)", sections.len())
            };
            return Err(invalid(path, reason));
        }
        let len = len as usize;
        sections.push(&rest[8..8 + len]);
        rest = &rest[8 + len..];
    }
    if count.is_some() {
        match rest.len() {
            0..4 => return Err(invalid(path, "truncated (the checksum is cut off)")),
            4 => {}
            n => return Err(invalid(path, format!("damaged: {} bytes follow the last section", n - 4))),
        }
        let body = &bytes[..bytes.len() - 4];
        let stored = u32::from_le_bytes(rest.try_into().expect("4 bytes"));
        if crc32fast::hash(body) != stored {
            return Err(invalid(path, "damaged: the checksum does not match the contents (a changed byte)"));
        }
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
        let mut f = ChecksummedWriter {
            inner: std::io::BufWriter::new(std::fs::File::create(&tmp)?),
            crc: crc32fast::Hasher::new(),
        };
        f.write_all(MAGIC)?;
        f.write_all(&VERSION.to_le_bytes())?;
        f.write_all(&(sections.len() as u32).to_le_bytes())?;
        for section in sections {
            f.write_all(&(section.len() as u64).to_le_bytes())?;
            f.write_all(section)?;
        }
        let crc = f.crc.finalize();
        let mut f = f.inner;
        f.write_all(&crc.to_le_bytes())?;
        f.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    };
    write().map_err(|source| {
        let _ = std::fs::remove_file(&tmp);
        CheckpointError::Io { path: path.into(), source }
    })
}

/// A writer that checksums what passes through it.
struct ChecksummedWriter<W> {
    inner: W,
    crc: crc32fast::Hasher,
}

impl<W: Write> Write for ChecksummedWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.crc.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
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

    /// Any flipped byte, any cut and any appended bytes are refused, with a message that says
    /// the file is damaged or truncated; the intact file reads back its sections.
    #[test]
    fn damaged_checkpoints_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.lucid");
        let payload: Vec<u8> = (0..300u32).map(|i| (i * 7) as u8).collect();
        write_sections(&path, &[br#"{"kind": "splat"}"#, &payload, b""]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let (value, sections) = read_kind_sections(&path, "splat").unwrap();
        assert_eq!(value["kind"], "splat");
        assert_eq!(sections, vec![payload.clone(), Vec::new()]);
        let refused = |damaged: &[u8]| -> String {
            let p = dir.path().join("d.lucid");
            std::fs::write(&p, damaged).unwrap();
            read_kind_sections(&p, "splat").unwrap_err().to_string()
        };
        for i in 0..bytes.len() {
            for bit in [0x01u8, 0x80] {
                let mut d = bytes.clone();
                d[i] ^= bit;
                let err = refused(&d);
                assert!(
                    ["damaged", "bad magic", "version", "truncated"].iter().any(|w| err.contains(w)),
                    "byte {i}: {err}"
                );
            }
        }
        for cut in 0..bytes.len() {
            let err = refused(&bytes[..cut]);
            assert!(err.contains("damaged") || err.contains("truncated") || err.contains("magic"), "cut {cut}: {err}");
        }
        let mut appended = bytes.clone();
        appended.extend_from_slice(b"garbage appended by something else");
        let err = refused(&appended);
        assert!(err.contains("damaged") && !err.contains("7450474826515505511"), "{err}");
    }

    /// Files of the first format (no count, no checksum) still load.
    #[test]
    fn version_1_files_still_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v1.lucid");
        let header = br#"{"kind": "nerf"}"#;
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&1u32.to_le_bytes());
        for s in [&header[..], &[1, 2, 3]] {
            bytes.extend_from_slice(&(s.len() as u64).to_le_bytes());
            bytes.extend_from_slice(s);
        }
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(read_kind(&path).unwrap(), "nerf");
        assert_eq!(read_kind_sections(&path, "nerf").unwrap().1, vec![vec![1, 2, 3]]);
    }
}
