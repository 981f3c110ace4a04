//! Animated PNG (APNG): the frames of a novel-view path as one file that browsers and image
//! viewers play, in full 8-bit colour (a GIF would quantise to 256 colours). Frames are
//! encoded as they come, so a long path never sits in memory; the file is written under a
//! temporary name and renamed into place by [`AnimatedPng::finish`], so an interrupted render
//! leaves nothing half-written.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use crate::color::srgb_encode;
use crate::{Image, ImageError};

/// An animation being written.
pub struct AnimatedPng {
    writer: Option<png::Writer<BufWriter<File>>>,
    /// The same file, to flush to disk once the encoder has finished with it.
    file: File,
    path: PathBuf,
    tmp: PathBuf,
    size: (usize, usize),
    frames: u32,
    written: u32,
}

impl AnimatedPng {
    /// Starts `path`: `frames` frames of `width`×`height`, played at `fps` frames per second,
    /// looping.
    pub fn create(path: &Path, width: usize, height: usize, frames: u32, fps: f64) -> Result<Self, ImageError> {
        let fail = |reason: String| ImageError::Encode { path: path.to_path_buf(), format: "APNG", reason };
        if frames == 0 || width == 0 || height == 0 || !(fps.is_finite() && fps > 0.0) {
            return Err(fail(format!("{frames} frames of {width}x{height} at {fps} fps is not an animation")));
        }
        let tmp = super::temporary_sibling(path);
        let file = File::create(&tmp).map_err(|e| ImageError::io(path, e))?;
        let handle = file.try_clone().map_err(|e| ImageError::io(path, e))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), width as u32, height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        // The delay as a fraction of a second: 1/fps, in milliseconds where fps is not whole.
        let (num, den) = if fps.fract() == 0.0 && fps <= f64::from(u16::MAX) {
            (1, fps as u16)
        } else {
            ((1000.0 / fps).round().clamp(1.0, f64::from(u16::MAX)) as u16, 1000)
        };
        let started = encoder
            .set_animated(frames, 0)
            .and_then(|()| encoder.set_frame_delay(num, den))
            .and_then(|()| encoder.write_header());
        let writer = started.map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            fail(e.to_string())
        })?;
        Ok(Self {
            writer: Some(writer),
            file: handle,
            path: path.to_path_buf(),
            tmp,
            size: (width, height),
            frames,
            written: 0,
        })
    }

    /// Appends a frame (linear colour, encoded to sRGB like every PNG Lucid writes).
    pub fn push(&mut self, image: &Image) -> Result<(), ImageError> {
        let fail = |reason: String| ImageError::Encode { path: self.path.clone(), format: "APNG", reason };
        if image.dimensions() != self.size {
            return Err(fail(format!("a frame of {:?}, the animation's are {:?}", image.dimensions(), self.size)));
        }
        if self.written == self.frames {
            return Err(fail(format!("more than the {} frames announced", self.frames)));
        }
        let bytes: Vec<u8> = image
            .pixels()
            .iter()
            .flat_map(|p| [p[0], p[1], p[2]])
            .map(|v| (srgb_encode(v.max(0.0)).min(1.0) * 255.0).round() as u8)
            .collect();
        let writer = self.writer.as_mut().expect("open until finished");
        writer.write_image_data(&bytes).map_err(|e| fail(e.to_string()))?;
        self.written += 1;
        Ok(())
    }

    /// Completes the file and moves it into place; every announced frame must have been
    /// pushed.
    pub fn finish(mut self) -> Result<(), ImageError> {
        let fail = |reason: String| ImageError::Encode { path: self.path.clone(), format: "APNG", reason };
        if self.written != self.frames {
            return Err(fail(format!("{} of {} frames written", self.written, self.frames)));
        }
        let writer = self.writer.take().expect("open until finished");
        if let Err(e) = writer.finish() {
            let _ = std::fs::remove_file(&self.tmp);
            return Err(fail(e.to_string()));
        }
        let synced = self.file.sync_all().and_then(|()| std::fs::rename(&self.tmp, &self.path));
        synced.map_err(|e| {
            let _ = std::fs::remove_file(&self.tmp);
            ImageError::io(&self.path, e)
        })
    }
}

impl Drop for AnimatedPng {
    /// An animation dropped unfinished (an error, an interrupted render) leaves no file.
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The frames read back, in order, at the delay asked for.
    #[test]
    fn frames_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("orbit.png");
        let frame = |k: usize| Image::from_fn(6, 4, |x, y| [(x + k) as f32 / 10.0, y as f32 / 4.0, 0.5, 1.0]);
        let mut video = AnimatedPng::create(&path, 6, 4, 3, 24.0).unwrap();
        for k in 0..3 {
            video.push(&frame(k)).unwrap();
        }
        assert!(video.push(&Image::black(5, 4)).is_err(), "a frame of another size");
        video.finish().unwrap();
        let mut decoder = png::Decoder::new(std::io::BufReader::new(File::open(&path).unwrap())).read_info().unwrap();
        let actl = decoder.info().animation_control.unwrap();
        assert_eq!((actl.num_frames, actl.num_plays), (3, 0));
        let mut buf = vec![0; decoder.output_buffer_size().unwrap()];
        for k in 0..3 {
            decoder.next_frame(&mut buf).unwrap();
            let fctl = decoder.info().frame_control.unwrap();
            assert_eq!((fctl.delay_num, fctl.delay_den), (1, 24));
            let want: Vec<u8> = frame(k)
                .pixels()
                .iter()
                .flat_map(|p| [p[0], p[1], p[2]])
                .map(|v| (srgb_encode(v) * 255.0).round() as u8)
                .collect();
            assert_eq!(&buf[..want.len()], &want[..], "frame {k}");
        }
    }

    /// Unfinished animations leave nothing; an incomplete one is refused.
    #[test]
    fn unfinished_animations_leave_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let mut video = AnimatedPng::create(&path, 2, 2, 2, 30.0).unwrap();
        video.push(&Image::black(2, 2)).unwrap();
        assert!(video.finish().is_err());
        drop(AnimatedPng::create(&path, 2, 2, 2, 30.0).unwrap());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "no file, no temporary");
    }
}
