//! A run's output folder: owned by one process at a time (an advisory lock), never silently
//! mixed with another run, and described by `run.json` (the model kind and the budget), so a
//! resumed run knows what it continues.

use std::path::{Path, PathBuf};

use lucid_image::output::OutputLock;
use serde::{Deserialize, Serialize};

use super::{Budget, RunError};

/// The folder's description of its run.
pub const MANIFEST: &str = "run.json";

/// The checkpoint of the run's (last) stage.
pub const CHECKPOINT: &str = "checkpoint.lucid";

/// Every name a training run writes in its folder; `--overwrite` removes these and only these.
pub const RUN_FILES: &[&str] = &[
    MANIFEST,
    CHECKPOINT,
    "config.toml",
    "train_log.csv",
    "splats.ply",
    "geometry.lucid",
    "geometry.ply",
    "geometry_log.csv",
    "eval_train",
    "eval_val",
    "eval_test",
];

/// How a run starts in its folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// A new run: the folder must hold no run.
    New,
    /// Continue the run of the same kind in the folder.
    Resume,
    /// A new run replacing the one in the folder (its files are removed first).
    Overwrite,
}

/// What `run.json` says.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    /// The model kind (`nerf`, `splat`, `itm`, `relight`).
    pub kind: String,
    /// The run's budget.
    pub budget: Budget,
    /// The fingerprint of the training data (absent in folders written before it was kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<String>,
}

/// An output folder held by this process.
#[derive(Debug)]
pub struct RunFolder {
    dir: PathBuf,
    previous: Option<Manifest>,
    lock: Option<OutputLock>,
    /// The fingerprint of the data this run trains on.
    dataset: Option<String>,
    /// This process made the folder: if the run fails before writing anything into it (a
    /// bad configuration, an unreadable image), it is removed again rather than left empty.
    created: bool,
}

impl Drop for RunFolder {
    fn drop(&mut self) {
        drop(self.lock.take());
        if self.created {
            // Fails, harmlessly, unless the folder is empty.
            let _ = std::fs::remove_dir(&self.dir);
        }
    }
}

impl RunFolder {
    /// Creates (if needed) and locks `dir` for a run of `kind`, checking what it holds against
    /// `start`. Nothing in the folder changes unless every check passes.
    pub fn open(dir: &Path, kind: &str, start: Start) -> Result<Self, RunError> {
        let folder_error = |reason: String| RunError::Folder { dir: dir.to_path_buf(), reason };
        if start == Start::Resume && !dir.is_dir() {
            return Err(folder_error(format!("nothing to resume: no such folder (no {CHECKPOINT})")));
        }
        let created = !dir.exists();
        std::fs::create_dir_all(dir).map_err(|source| RunError::Io { path: dir.to_path_buf(), source })?;
        let lock = OutputLock::folder(dir).map_err(|e| RunError::Lock(Box::new(e)))?;
        let found: Vec<&str> = RUN_FILES.iter().copied().filter(|name| dir.join(name).exists()).collect();
        let previous = read_manifest(&dir.join(MANIFEST))?;
        let checkpoint = dir.join(CHECKPOINT);
        let held_kind = match &previous {
            Some(m) => Some(m.kind.clone()),
            None if checkpoint.is_file() => Some(crate::checkpoint::read_kind(&checkpoint)?),
            None => None,
        };
        match start {
            Start::New if !found.is_empty() => {
                let what = held_kind.map_or("files of a run".to_string(), |k| format!("a '{k}' run"));
                return Err(folder_error(format!(
                    "already holds {what} ({}); pass --resume to continue it or --overwrite to replace it",
                    found.join(", ")
                )));
            }
            Start::New => {}
            Start::Overwrite => {
                if held_kind.is_none() && !found.is_empty() {
                    return Err(folder_error(format!(
                        "holds {} but no Lucid run (no {MANIFEST} or {CHECKPOINT}); Lucid does not remove files it \
                         did not write: choose another folder",
                        found.join(", ")
                    )));
                }
                // Evaluation folders lose only the files their record lists: a user's notes stay.
                for name in &found {
                    let path = dir.join(name);
                    if path.is_dir() {
                        let image_error =
                            |e: lucid_image::owned_folder::FolderError| RunError::Image(Box::new(e.into()));
                        lucid_image::owned_folder::adopt_unrecorded_evaluation(&path).map_err(image_error)?;
                        lucid_image::owned_folder::remove_written(&path, "--overwrite").map_err(image_error)?;
                    } else {
                        std::fs::remove_file(&path).map_err(|source| RunError::Io { path, source })?;
                    }
                }
            }
            Start::Resume => match held_kind {
                None => {
                    return Err(folder_error(format!(
                        "nothing to resume: no {CHECKPOINT} or {MANIFEST} (a run saves its first checkpoint after a \
                         minute or its first checkpoint interval)"
                    )));
                }
                Some(k) if k != kind => {
                    return Err(folder_error(format!(
                        "holds a '{k}' run ({}), which cannot be resumed as '{kind}'",
                        found.join(", ")
                    )));
                }
                Some(_) => {}
            },
        }
        let previous = if start == Start::Resume { previous } else { None };
        Ok(Self { dir: dir.to_path_buf(), previous, lock: Some(lock), dataset: None, created })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// A file in the folder.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// The checkpoint of the run's last stage.
    pub fn checkpoint(&self) -> PathBuf {
        self.path(CHECKPOINT)
    }

    /// The budget of the run being resumed, if its folder recorded one.
    pub fn previous_budget(&self) -> Option<Budget> {
        self.previous.as_ref().map(|m| m.budget)
    }

    /// Names the data the run trains on (a fingerprint); a resumed run whose folder recorded
    /// other data is refused.
    pub fn check_dataset(&mut self, fingerprint: String) -> Result<(), RunError> {
        if let Some(recorded) = self.previous.as_ref().and_then(|m| m.dataset.as_deref())
            && recorded != fingerprint
        {
            return Err(RunError::Folder {
                dir: self.dir.clone(),
                reason: format!(
                    "the run trained on other data (fingerprint {recorded}; this dataset's is {fingerprint}): resume it \
                     on the dataset it began with, or start a new run"
                ),
            });
        }
        self.dataset = Some(fingerprint);
        Ok(())
    }

    /// Records the run's kind, budget and data in `run.json`.
    pub fn write_manifest(&self, kind: &str, budget: Budget) -> Result<(), RunError> {
        let manifest = Manifest { kind: kind.into(), budget, dataset: self.dataset.clone() };
        let text = serde_json::to_string_pretty(&manifest).expect("serialises");
        lucid_image::output::write_text(&self.path(MANIFEST), &text).map_err(|e| RunError::Image(Box::new(e)))
    }
}

fn read_manifest(path: &Path) -> Result<Option<Manifest>, RunError> {
    match std::fs::read_to_string(path) {
        Ok(text) => serde_json::from_str(&text).map(Some).map_err(|e| RunError::Folder {
            dir: path.to_path_buf(),
            reason: format!("malformed run description: {e}"),
        }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(RunError::Io { path: path.to_path_buf(), source }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut files: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file() && !p.ends_with(lucid_image::output::LOCK_FILE))
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
            .collect();
        files.sort();
        files
    }

    #[test]
    fn a_folder_with_a_run_is_refused_unless_resumed_as_its_kind_or_overwritten() {
        let dir = tempfile::tempdir().unwrap();
        let run = RunFolder::open(dir.path(), "splat", Start::New).unwrap();
        run.write_manifest("splat", Budget::Steps { steps: 10 }).unwrap();
        // Held: a second writer is told who holds it.
        let held = RunFolder::open(dir.path(), "nerf", Start::Overwrite).unwrap_err().to_string();
        assert!(held.contains("in use by another lucid process"), "{held}");
        drop(run);
        std::fs::write(dir.path().join("splats.ply"), b"ply").unwrap();
        std::fs::write(dir.path().join("notes.txt"), b"mine").unwrap();
        let before = snapshot(dir.path());

        let new = RunFolder::open(dir.path(), "nerf", Start::New).unwrap_err().to_string();
        assert!(new.contains("already holds a 'splat' run") && new.contains("--overwrite"), "{new}");
        let other = RunFolder::open(dir.path(), "nerf", Start::Resume).unwrap_err().to_string();
        assert!(other.contains("cannot be resumed as 'nerf'"), "{other}");
        assert_eq!(snapshot(dir.path()), before);

        let same = RunFolder::open(dir.path(), "splat", Start::Resume).unwrap();
        assert_eq!(same.previous_budget(), Some(Budget::Steps { steps: 10 }));
        // Its evaluation, and a note the user added to it.
        let eval = lucid_image::owned_folder::OwnedFolder::claim(&same.path("eval_test"), "eval", &[]).unwrap();
        std::fs::write(eval.path("metrics.json"), b"{}").unwrap();
        drop(eval);
        std::fs::write(dir.path().join("eval_test/notes.txt"), b"also mine").unwrap();
        drop(same);
        drop(RunFolder::open(dir.path(), "nerf", Start::Overwrite).unwrap());
        // The run's files are gone; the user's are not.
        assert_eq!(snapshot(dir.path()), vec![("notes.txt".to_string(), b"mine".to_vec())]);
        assert_eq!(std::fs::read(dir.path().join("eval_test/notes.txt")).unwrap(), b"also mine");
        assert!(!dir.path().join("eval_test/metrics.json").exists());
    }

    #[test]
    fn a_run_resumes_only_on_the_data_it_began_with() {
        let dir = tempfile::tempdir().unwrap();
        let mut run = RunFolder::open(dir.path(), "nerf", Start::New).unwrap();
        run.check_dataset("aaaa".into()).unwrap();
        run.write_manifest("nerf", Budget::Steps { steps: 5 }).unwrap();
        drop(run);
        let mut other = RunFolder::open(dir.path(), "nerf", Start::Resume).unwrap();
        let refused = other.check_dataset("bbbb".into()).unwrap_err().to_string();
        assert!(refused.contains("other data") && refused.contains("aaaa") && refused.contains("bbbb"), "{refused}");
        drop(other);
        let mut same = RunFolder::open(dir.path(), "nerf", Start::Resume).unwrap();
        same.check_dataset("aaaa".into()).unwrap();
        // A run.json from before fingerprints were kept resumes on any data.
        std::fs::write(dir.path().join(MANIFEST), r#"{"kind": "nerf", "budget": {"mode": "steps", "steps": 5}}"#)
            .unwrap();
        drop(same);
        let mut old = RunFolder::open(dir.path(), "nerf", Start::Resume).unwrap();
        old.check_dataset("cccc".into()).unwrap();
    }

    #[test]
    fn a_folder_made_for_a_run_that_wrote_nothing_is_removed_again() {
        let dir = tempfile::tempdir().unwrap();
        let new = dir.path().join("run");
        drop(RunFolder::open(&new, "nerf", Start::New).unwrap());
        assert!(!new.exists(), "a failed run leaves no empty folder");
        let run = RunFolder::open(&new, "nerf", Start::New).unwrap();
        run.write_manifest("nerf", Budget::Steps { steps: 1 }).unwrap();
        drop(run);
        assert!(new.join(MANIFEST).is_file());
        // A folder the user made stays, empty or not.
        let theirs = dir.path().join("theirs");
        std::fs::create_dir(&theirs).unwrap();
        drop(RunFolder::open(&theirs, "nerf", Start::New).unwrap());
        assert!(theirs.is_dir());
    }

    #[test]
    fn files_that_no_lucid_run_wrote_are_never_removed() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("config.toml"), b"mine").unwrap();
        let err = RunFolder::open(dir.path(), "nerf", Start::Overwrite).unwrap_err().to_string();
        assert!(err.contains("no Lucid run"), "{err}");
        let resume = RunFolder::open(dir.path(), "nerf", Start::Resume).unwrap_err().to_string();
        assert!(resume.contains("nothing to resume"), "{resume}");
        assert_eq!(std::fs::read(dir.path().join("config.toml")).unwrap(), b"mine");
    }
}
