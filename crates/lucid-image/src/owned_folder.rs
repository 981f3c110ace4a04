//! Output folders that Lucid owns: made by it, or holding its record of the files it wrote
//! there (`.lucid-output.json`). A command writes only into such a folder, never into one
//! that holds files of someone else's, never over one of its own inputs, and one process at a
//! time (the folder is locked while claimed). Removing an earlier output removes only the files
//! its record lists, so whatever a user added to the folder stays.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde_json::{Value, json};

use crate::output::{LockError, OutputLock, is_lock_file, write_text};

/// The record of what Lucid wrote in a folder.
pub const RECORD_FILE: &str = ".lucid-output.json";

/// Why an output folder cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FolderError {
    /// The folder holds files that no record says Lucid wrote.
    #[error(
        "{}: holds files that Lucid did not write ({found}); {writer} writes only into a new or empty folder or one it made, and leaves this one untouched: choose another output",
        dir.display()
    )]
    Foreign {
        /// The folder.
        dir: PathBuf,
        /// The command that would have written.
        writer: String,
        /// Some of the files found.
        found: String,
    },
    /// An input of the command lies inside the folder it would write.
    #[error("{}: is an input of this command and lies inside its output folder {}; choose another output", input.display(), dir.display())]
    Input {
        /// The folder.
        dir: PathBuf,
        /// The input.
        input: PathBuf,
    },
    /// Another process holds the folder.
    #[error(transparent)]
    Lock(#[from] LockError),
    /// Reading or writing failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The record is not one Lucid writes.
    #[error("{}: {reason}", path.display())]
    Record {
        /// The record file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FolderError + '_ {
    move |source| FolderError::Io { path: path.to_path_buf(), source }
}

/// Size and modification time of each file under a folder, by relative path.
type Snapshot = BTreeMap<String, (u64, Option<SystemTime>)>;

/// A folder this process writes into, held until dropped; dropping it records the files
/// written since it was claimed (also when the command failed part-way, so a later run can
/// replace them).
#[derive(Debug)]
pub struct OwnedFolder {
    dir: PathBuf,
    writer: String,
    /// What the record listed when the folder was claimed.
    recorded: BTreeSet<String>,
    before: Snapshot,
    created: bool,
    lock: Option<OutputLock>,
}

impl OwnedFolder {
    /// Claims `dir` for `writer` (a command's name, as messages show it): it is created, or
    /// must be empty or hold Lucid's record, and none of `inputs` may lie inside it. Nothing
    /// is created or changed unless every check passes.
    pub fn claim(dir: &Path, writer: &str, inputs: &[&Path]) -> Result<Self, FolderError> {
        if let Ok(root) = dir.canonicalize() {
            for input in inputs {
                if input.canonicalize().is_ok_and(|p| p.starts_with(&root)) {
                    return Err(FolderError::Input { dir: dir.to_path_buf(), input: input.to_path_buf() });
                }
            }
        }
        let created = !dir.exists();
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let lock = OutputLock::folder(dir)?;
        let recorded = read_record(dir)?;
        let before = snapshot(dir)?;
        if recorded.is_none() && !before.is_empty() {
            return Err(foreign(dir, writer, &before));
        }
        // Marked as Lucid's before anything is written: a process killed part-way leaves a
        // folder that its rerun may use.
        if recorded.is_none() {
            write_record(dir, writer, std::iter::empty::<&str>())?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            writer: writer.to_string(),
            recorded: recorded.unwrap_or_default(),
            before,
            created,
            lock: Some(lock),
        })
    }

    /// A path in the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes the record now (as dropping does) and lets go of the folder.
    pub fn finish(mut self) -> Result<(), FolderError> {
        self.record_written()
    }

    fn record_written(&mut self) -> Result<(), FolderError> {
        let Some(lock) = self.lock.take() else { return Ok(()) };
        let now = snapshot(&self.dir)?;
        let written = now.iter().filter(|(name, stamp)| self.before.get(*name) != Some(stamp)).map(|(n, _)| n.clone());
        let files: BTreeSet<String> =
            self.recorded.iter().filter(|n| now.contains_key(*n)).cloned().chain(written).collect();
        if files.is_empty() && self.created {
            // Nothing written into a folder made for it: the folder goes again.
            drop(lock);
            let _ = std::fs::remove_file(self.dir.join(RECORD_FILE));
            let _ = std::fs::remove_dir(&self.dir);
            return Ok(());
        }
        let result = write_record(&self.dir, &self.writer, &files);
        drop(lock);
        result
    }
}

impl Drop for OwnedFolder {
    fn drop(&mut self) {
        // lucid-image has no logger, and a drop cannot fail: the warning goes to stderr.
        if let Err(e) = self.record_written() {
            eprintln!("warning: {e}");
        }
    }
}

/// Whether `dir` holds Lucid's record of an output.
pub fn is_owned(dir: &Path) -> bool {
    dir.join(RECORD_FILE).is_file()
}

/// Removes the files Lucid's record in `dir` lists, the record, folders this leaves empty
/// and `dir` itself if it ends up empty; files the record does not list stay. A folder with
/// files but no record is refused.
pub fn remove_written(dir: &Path, writer: &str) -> Result<(), FolderError> {
    if !dir.exists() {
        return Ok(());
    }
    let lock = OutputLock::folder(dir)?;
    let Some(files) = read_record(dir)? else {
        let found = snapshot(dir)?;
        if found.is_empty() {
            drop(lock);
            let _ = std::fs::remove_dir(dir);
            return Ok(());
        }
        return Err(foreign(dir, writer, &found));
    };
    let mut parents = BTreeSet::new();
    for name in &files {
        let path = dir.join(name);
        match std::fs::remove_file(&path) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(FolderError::Io { path, source: e }),
        }
        let mut parent = Path::new(name).parent();
        while let Some(p) = parent.filter(|p| !p.as_os_str().is_empty()) {
            parents.insert(p.to_path_buf());
            parent = p.parent();
        }
    }
    // Deepest first; a folder that still holds something stays.
    for p in parents.iter().rev() {
        let _ = std::fs::remove_dir(dir.join(p));
    }
    std::fs::remove_file(dir.join(RECORD_FILE)).map_err(io(&dir.join(RECORD_FILE)))?;
    drop(lock);
    let _ = std::fs::remove_dir(dir);
    Ok(())
}

/// Gives an evaluation folder written before folders kept a record (its `metrics.json` lists
/// the views it scored) the record of what the evaluation wrote there: `metrics.json` and, per
/// view, `<stem>.png`, `<stem>_depth.exr` and `<stem>_error.png`; anything else in the folder is
/// left out, so it stays someone else's. Does nothing to a folder with a record or without such
/// a `metrics.json`.
pub fn adopt_unrecorded_evaluation(dir: &Path) -> Result<(), FolderError> {
    if is_owned(dir) {
        return Ok(());
    }
    let Ok(text) = std::fs::read_to_string(dir.join("metrics.json")) else { return Ok(()) };
    let Ok(report) = serde_json::from_str::<Value>(&text) else { return Ok(()) };
    let (Some(views), true) = (report["views"].as_array(), report.get("metric_space").is_some()) else {
        return Ok(());
    };
    let mut files = vec!["metrics.json".to_string()];
    for view in views {
        let Some(stem) = view["image"].as_str().and_then(|p| Path::new(p).file_stem()?.to_str().map(String::from))
        else {
            continue;
        };
        for name in [format!("{stem}.png"), format!("{stem}_depth.exr"), format!("{stem}_error.png")] {
            if dir.join(&name).is_file() {
                files.push(name);
            }
        }
    }
    write_record(dir, "the evaluation", &files)
}

/// Writes `dir`'s record: `writer` wrote `files` (paths inside `dir`, `/`-separated). Adopting
/// an output from before records is writing one for it; otherwise [`OwnedFolder`] keeps it.
pub fn write_record<S: AsRef<str>>(
    dir: &Path,
    writer: &str,
    files: impl IntoIterator<Item = S>,
) -> Result<(), FolderError> {
    let files: Vec<String> = files.into_iter().map(|f| f.as_ref().to_string()).collect();
    let text = serde_json::to_string_pretty(&json!({ "writer": writer, "files": files })).expect("serialises");
    let path = dir.join(RECORD_FILE);
    write_text(&path, &text).map_err(|e| FolderError::Record { path: path.clone(), reason: e.to_string() })
}

/// The refusal of a folder holding `found` and no record, naming a few of its files.
fn foreign(dir: &Path, writer: &str, found: &Snapshot) -> FolderError {
    let shown: Vec<&str> = found.keys().take(4).map(String::as_str).collect();
    let more = if found.len() > 4 { format!(" and {} more", found.len() - 4) } else { String::new() };
    FolderError::Foreign {
        dir: dir.to_path_buf(),
        writer: writer.to_string(),
        found: format!("{}{more}", shown.join(", ")),
    }
}

fn read_record(dir: &Path) -> Result<Option<BTreeSet<String>>, FolderError> {
    let path = dir.join(RECORD_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(FolderError::Io { path, source: e }),
    };
    let bad = |reason: &str| FolderError::Record { path: path.clone(), reason: reason.to_string() };
    let value: Value = serde_json::from_str(&text).map_err(|e| bad(&format!("not Lucid's output record: {e}")))?;
    let files = value["files"].as_array().ok_or_else(|| bad("not Lucid's output record: no 'files' list"))?;
    files
        .iter()
        .map(|f| {
            let name = f.as_str().ok_or_else(|| bad("a file name in 'files' is not a string"))?;
            // A record names files inside its folder, never outside it.
            let inside = Path::new(name).components().all(|c| matches!(c, std::path::Component::Normal(_)));
            if !inside {
                return Err(bad(&format!("'{name}' is not a path inside the folder")));
            }
            Ok(name.to_string())
        })
        .collect::<Result<_, _>>()
        .map(Some)
}

/// Every file under `dir` but the record, lock files and unfinished temporaries.
fn snapshot(dir: &Path) -> Result<Snapshot, FolderError> {
    let mut files = Snapshot::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(relative) = stack.pop() {
        let folder = dir.join(&relative);
        for entry in std::fs::read_dir(&folder).map_err(io(&folder))? {
            let entry = entry.map_err(io(&folder))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if relative.as_os_str().is_empty() && name == RECORD_FILE {
                continue;
            }
            if is_lock_file(&name) || (name.starts_with('.') && name.ends_with(".tmp")) {
                continue;
            }
            let path = relative.join(&name);
            let kind = entry.file_type().map_err(io(&entry.path()))?;
            if kind.is_dir() {
                stack.push(path);
            } else {
                let meta = entry.metadata().map_err(io(&entry.path()))?;
                let key = path.to_string_lossy().replace('\\', "/");
                files.insert(key, (meta.len(), meta.modified().ok()));
            }
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        snapshot(dir).unwrap().into_keys().collect()
    }

    #[test]
    fn a_folder_of_someone_elses_files_is_refused_and_left_as_it_was() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("test");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("r_0.png"), "truth").unwrap();
        let err = OwnedFolder::claim(&dir, "lucid eval", &[]).unwrap_err();
        assert!(matches!(err, FolderError::Foreign { .. }), "{err}");
        assert!(err.to_string().contains("r_0.png") && err.to_string().contains("lucid eval"), "{err}");
        assert_eq!(names(&dir), ["r_0.png"]);
        assert!(!dir.join(RECORD_FILE).exists() && !dir.join(crate::output::LOCK_FILE).exists());
    }

    #[test]
    fn an_input_inside_the_output_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("camera_path.json");
        std::fs::write(&path, "{}").unwrap();
        let err = OwnedFolder::claim(tmp.path(), "lucid render", &[&path]).unwrap_err();
        assert!(matches!(err, FolderError::Input { .. }), "{err}");
        // An input elsewhere is no obstacle.
        let out = tmp.path().join("frames");
        OwnedFolder::claim(&out, "lucid render", &[&path]).unwrap();
        assert!(!out.exists(), "a folder made and left empty is removed");
    }

    #[test]
    fn removing_an_output_keeps_what_the_user_added() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("eval_test");
        let owned = OwnedFolder::claim(&dir, "lucid eval", &[]).unwrap();
        std::fs::create_dir(owned.path("sub")).unwrap();
        std::fs::write(owned.path("metrics.json"), "{}").unwrap();
        std::fs::write(owned.path("sub/a.png"), "a").unwrap();
        owned.finish().unwrap();
        // The user adds a note; a second claim (a rerun) is allowed and keeps it out of the record.
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        let again = OwnedFolder::claim(&dir, "lucid eval", &[]).unwrap();
        std::fs::write(again.path("metrics.json"), "{\"again\": 1}").unwrap();
        drop(again);
        let record: Value = serde_json::from_str(&std::fs::read_to_string(dir.join(RECORD_FILE)).unwrap()).unwrap();
        assert_eq!(record["files"], json!(["metrics.json", "sub/a.png"]));
        remove_written(&dir, "lucid train --overwrite").unwrap();
        assert_eq!(names(&dir), ["notes.txt"]);
        assert!(!dir.join(RECORD_FILE).exists() && !dir.join("sub").exists());
        // A folder of only Lucid's files goes entirely.
        let other = tmp.path().join("eval_val");
        let owned = OwnedFolder::claim(&other, "lucid eval", &[]).unwrap();
        std::fs::write(owned.path("metrics.json"), "{}").unwrap();
        drop(owned);
        remove_written(&other, "lucid train --overwrite").unwrap();
        assert!(!other.exists());
        // A folder with files and no record is not removed.
        let foreign = tmp.path().join("foreign");
        std::fs::create_dir(&foreign).unwrap();
        std::fs::write(foreign.join("x"), "x").unwrap();
        assert!(remove_written(&foreign, "lucid train --overwrite").is_err());
        assert_eq!(names(&foreign), ["x"]);
    }

    #[test]
    fn an_evaluation_from_before_records_is_adopted_without_the_users_files() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let report = json!({ "metric_space": "sRGB", "views": [{ "image": "ds/test/r_0.png" }] });
        std::fs::write(dir.join("metrics.json"), report.to_string()).unwrap();
        for name in ["r_0.png", "r_0_depth.exr", "r_0_error.png", "notes.txt"] {
            std::fs::write(dir.join(name), name).unwrap();
        }
        adopt_unrecorded_evaluation(dir).unwrap();
        remove_written(dir, "--overwrite").unwrap();
        assert_eq!(names(dir), ["notes.txt"]);
        // A folder of someone else's files with no evaluation's report is not adopted.
        let other = tmp.path().join("other");
        std::fs::create_dir(&other).unwrap();
        std::fs::write(other.join("metrics.json"), "{}").unwrap();
        adopt_unrecorded_evaluation(&other).unwrap();
        assert!(!is_owned(&other));
    }

    #[test]
    fn a_second_claim_waits_for_the_first() {
        let tmp = tempfile::tempdir().unwrap();
        let first = OwnedFolder::claim(tmp.path(), "lucid eval", &[]).unwrap();
        let err = OwnedFolder::claim(tmp.path(), "lucid eval", &[]).unwrap_err();
        assert!(matches!(err, FolderError::Lock(_)), "{err}");
        drop(first);
    }

    #[test]
    fn a_record_naming_files_outside_its_folder_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::write(tmp.path().join(RECORD_FILE), r#"{"files": ["../elsewhere"]}"#).unwrap();
        let err = remove_written(tmp.path(), "lucid train --overwrite").unwrap_err();
        assert!(err.to_string().contains("not a path inside"), "{err}");
    }
}
