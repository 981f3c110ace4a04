//! Text files as editors save them: a UTF-8 byte-order mark (Windows Notepad writes one) is
//! not part of the content.

use std::path::Path;

/// The file's text without a leading byte-order mark.
pub fn read_text(path: &Path) -> std::io::Result<String> {
    let text = std::fs::read_to_string(path)?;
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_byte_order_mark_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.json");
        std::fs::write(&path, "\u{feff}{\"a\": 1}").unwrap();
        assert_eq!(super::read_text(&path).unwrap(), "{\"a\": 1}");
        std::fs::write(&path, "plain").unwrap();
        assert_eq!(super::read_text(&path).unwrap(), "plain");
    }
}
