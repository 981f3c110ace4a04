//! `lucid render CHECKPOINT --video FILE`: the frames of a path as one video. An animated PNG
//! (`.png`, `.apng`) is written here, frame by frame, and plays in any browser; `.mp4`,
//! `.webm`, `.mkv` and `.mov` are encoded by `ffmpeg` from the written frames, when it is on
//! `PATH` (checked before anything renders). Either is written under a temporary name and
//! renamed into place, so a failed encode leaves nothing half-written.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, bail};
use lucid_image::Image;
use lucid_image::io::AnimatedPng;

/// A video being written.
pub enum Video {
    /// Frames pushed as they render.
    Apng(AnimatedPng),
    /// Encoded by ffmpeg from the frames once all are written.
    Ffmpeg {
        /// The video file.
        path: PathBuf,
        /// The ffmpeg binary.
        ffmpeg: PathBuf,
    },
}

impl Video {
    /// Starts `path` for `frames` frames of `width`×`height` at `fps`; fails at once if its
    /// format needs an ffmpeg that is not on `PATH`.
    pub fn create(path: &Path, width: usize, height: usize, frames: u32, fps: f64) -> anyhow::Result<Self> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("png" | "apng") => Ok(Self::Apng(AnimatedPng::create(path, width, height, frames, fps)?)),
            Some("mp4" | "webm" | "mkv" | "mov") => match find_on_path("ffmpeg") {
                Some(ffmpeg) => Ok(Self::Ffmpeg { path: path.to_path_buf(), ffmpeg }),
                None => bail!(
                    "{}: writing a video of this format needs ffmpeg on PATH, and there is none; \
                     --video FILE.apng writes an animated PNG without it",
                    path.display()
                ),
            },
            _ => bail!(
                "{}: --video writes .apng/.png (animated PNG) or, with ffmpeg, .mp4, .webm, .mkv or .mov",
                path.display()
            ),
        }
    }

    /// Adds the next frame (linear colour).
    pub fn push(&mut self, frame: &Image) -> anyhow::Result<()> {
        if let Self::Apng(apng) = self {
            apng.push(frame)?;
        }
        Ok(())
    }

    /// Finishes the file; `frames` is the folder of `frame_%04d.png` the render wrote.
    pub fn finish(self, frames: &Path, fps: f64) -> anyhow::Result<()> {
        match self {
            Self::Apng(apng) => Ok(apng.finish()?),
            Self::Ffmpeg { path, ffmpeg } => encode(&ffmpeg, frames, fps, &path),
        }
    }
}

fn encode(ffmpeg: &Path, frames: &Path, fps: f64, path: &Path) -> anyhow::Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("mp4").to_ascii_lowercase();
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("video");
    // ffmpeg picks the container from the extension, so the temporary name keeps it.
    let tmp = path.with_file_name(format!(".{name}.{}.tmp.{ext}", std::process::id()));
    let codec: &[&str] = if ext == "webm" {
        &["-c:v", "libvpx-vp9", "-b:v", "0", "-crf", "30"]
    } else {
        &["-c:v", "libx264", "-crf", "18", "-movflags", "+faststart"]
    };
    let output = Command::new(ffmpeg)
        .args(["-hide_banner", "-loglevel", "error", "-y", "-framerate", &format!("{fps}"), "-i"])
        .arg(frames.join("frame_%04d.png"))
        // 4:2:0 chroma needs even sides.
        .args(["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p"])
        .args(codec)
        .arg(&tmp)
        .output()
        .with_context(|| format!("running {}", ffmpeg.display()))?;
    if !output.status.success() {
        let _ = std::fs::remove_file(&tmp);
        bail!("{}: ffmpeg failed: {}", path.display(), String::from_utf8_lossy(&output.stderr).trim());
    }
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))
}

fn find_on_path(program: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?.to_str()?.split(':').map(|dir| Path::new(dir).join(program)).find(|p| p.is_file())
}
