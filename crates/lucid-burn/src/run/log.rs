//! The CSV log of a run: one header, then a row every `log_every` steps. A resumed run cuts
//! the log back to its checkpoint's step first, so that rows written after the checkpoint (and
//! lost with the process) are not followed by a second copy of the same steps.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::RunError;

/// An open training log.
pub struct TrainLog {
    file: BufWriter<File>,
    path: PathBuf,
}

impl TrainLog {
    /// Opens `path` with `header` (comma-separated column names, `step` first). With
    /// `resume_from = Some(step)`, keeps the rows up to that step (in increasing order), under
    /// one header; otherwise starts a new log.
    pub fn open(path: &Path, header: &str, resume_from: Option<usize>) -> Result<Self, RunError> {
        let io = |source| RunError::Io { path: path.to_path_buf(), source };
        let mut text = format!("{header}\n");
        if let Some(last) = resume_from {
            let old = match std::fs::read_to_string(path) {
                Ok(old) => old,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
                Err(e) => return Err(io(e)),
            };
            let mut previous = None;
            for line in old.lines() {
                // Rows start with their step; the header and anything torn do not parse.
                let Some(step) = line.split(',').next().and_then(|s| s.parse::<usize>().ok()) else { continue };
                if step <= last && previous.is_none_or(|p| step > p) && line.split(',').count() == header_len(header) {
                    text.push_str(line);
                    text.push('\n');
                    previous = Some(step);
                }
            }
        }
        lucid_image::output::write_text(path, &text).map_err(|e| RunError::Image(Box::new(e)))?;
        let file = std::fs::OpenOptions::new().append(true).open(path).map_err(io)?;
        Ok(Self { file: BufWriter::new(file), path: path.to_path_buf() })
    }

    /// Appends a row and flushes it.
    pub fn row(&mut self, fields: &[String]) -> Result<(), RunError> {
        writeln!(self.file, "{}", fields.join(","))
            .and_then(|()| self.file.flush())
            .map_err(|source| RunError::Io { path: self.path.clone(), source })
    }
}

fn header_len(header: &str) -> usize {
    header.split(',').count()
}

/// A log value with six significant digits, written as briefly as it reads back (integers as
/// integers).
pub fn format_value(v: f64) -> String {
    if !v.is_finite() {
        return v.to_string();
    }
    let rounded: f64 = format!("{v:.5e}").parse().unwrap_or(v);
    format!("{rounded}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resume_keeps_one_header_and_the_rows_up_to_the_checkpoint() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        let header = "step,seconds,loss";
        // A log with a duplicate step (an earlier resume), rows past the checkpoint and a torn
        // last line.
        std::fs::write(&path, "step,seconds,loss\n100,1,0.5\n200,2,0.4\n200,2.1,0.41\n300,3,0.3\n40").unwrap();
        let mut log = TrainLog::open(&path, header, Some(250)).unwrap();
        log.row(&["300".into(), "3.2".into(), "0.33".into()]).unwrap();
        drop(log);
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "step,seconds,loss\n100,1,0.5\n200,2,0.4\n300,3.2,0.33\n");

        // A log with no header (killed before its first row was flushed) gets one.
        std::fs::write(&path, "").unwrap();
        drop(TrainLog::open(&path, header, Some(50)).unwrap());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "step,seconds,loss\n");
        // A missing log too; a new run replaces an old log.
        std::fs::remove_file(&path).unwrap();
        drop(TrainLog::open(&path, header, Some(50)).unwrap());
        std::fs::write(&path, "step,seconds,loss\n1,1,1\n").unwrap();
        drop(TrainLog::open(&path, header, None).unwrap());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "step,seconds,loss\n");
    }

    #[test]
    fn values_are_brief_and_exact_to_six_digits() {
        assert_eq!(format_value(1200.0), "1200");
        assert_eq!(format_value(0.000123456789), "0.000123457");
        assert_eq!(format_value(f64::from(0.1f32)), "0.1");
        assert_eq!(format_value(f64::NAN), "NaN");
    }
}
