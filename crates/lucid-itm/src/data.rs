//! Training and evaluation pairs from `brackets` datasets: each LDR exposure with the
//! path-traced radiance times its exposure time (the HDR exposure it should map to).

use std::collections::HashMap;
use std::path::PathBuf;

use lucid_hdr::itm::clip_mask;
use lucid_hdr::stack::code_of;
use lucid_image::{Image, read_image};
use lucid_scene::sampling::Rng;
use lucid_scene::{Dataset, Split};

/// Why data could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A dataset could not be read.
    #[error(transparent)]
    Dataset(#[from] lucid_scene::DatasetError),
    /// An image could not be read.
    #[error(transparent)]
    Image(#[from] lucid_image::ImageError),
    /// The data do not fit together.
    #[error("{0}")]
    Invalid(String),
}

/// One LDR exposure and its truth, planar (`C×H×W`).
#[derive(Clone, Debug)]
pub struct ItmImage {
    /// Where it came from.
    pub name: String,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Display values `y` (the file's codes / 255), `3×H×W`.
    pub display: Vec<f32>,
    /// `f⁻¹(y)` (sRGB), `3×H×W`.
    pub linear: Vec<f32>,
    /// Clipping mask `α`, `H×W`.
    pub mask: Vec<f32>,
    /// Radiance × exposure time, `3×H×W`.
    pub truth: Vec<f32>,
    /// Pixels with `α > 0`.
    pub clipped: Vec<usize>,
}

impl ItmImage {
    /// A pair from an LDR frame (linear, as read) and its HDR exposure.
    pub fn new(name: String, ldr: &Image, truth: &Image, threshold: f32) -> Self {
        let (w, h) = ldr.dimensions();
        let n = w * h;
        let (mut display, mut linear, mut t) = (vec![0.0; 3 * n], vec![0.0; 3 * n], vec![0.0; 3 * n]);
        let mut mask = vec![0.0; n];
        let mut clipped = Vec::new();
        for (i, (p, q)) in ldr.pixels().iter().zip(truth.pixels()).enumerate() {
            let y = [0, 1, 2].map(|c| code_of(p[c]) as f32 / 255.0);
            for c in 0..3 {
                display[c * n + i] = y[c];
                linear[c * n + i] = lucid_hdr::itm::linearise(y[c]);
                t[c * n + i] = q[c].max(0.0);
            }
            mask[i] = clip_mask(y, threshold);
            if mask[i] > 0.0 {
                clipped.push(i);
            }
        }
        Self { name, width: w, height: h, display, linear, mask, truth: t, clipped }
    }
}

/// Every bracket frame of `split` in the given datasets.
pub fn load(datasets: &[PathBuf], split: Split, threshold: f32) -> Result<Vec<ItmImage>, DataError> {
    let mut out = Vec::new();
    for root in datasets {
        let dataset = Dataset::open(root)?;
        let mut truths: HashMap<PathBuf, Image> = HashMap::new();
        for f in dataset.frames(split) {
            let (Some(time), Some(hdr)) = (f.extras.exposure_time, &f.extras.hdr_path) else { continue };
            if !truths.contains_key(hdr) {
                truths.insert(hdr.clone(), read_image(hdr)?);
            }
            let truth = &truths[hdr];
            let ldr = read_image(&f.image_path)?;
            if ldr.dimensions() != truth.dimensions() {
                return Err(DataError::Invalid(format!(
                    "{}: {}x{}, but its HDR truth {} is {}x{}",
                    f.image_path.display(),
                    ldr.width(),
                    ldr.height(),
                    hdr.display(),
                    truth.width(),
                    truth.height()
                )));
            }
            let exposed = truth.map(|p| [p[0] * time, p[1] * time, p[2] * time, p[3]]);
            out.push(ItmImage::new(f.image_path.display().to_string(), &ldr, &exposed, threshold));
        }
    }
    if out.is_empty() {
        let names: Vec<String> = datasets.iter().map(|d| d.display().to_string()).collect();
        return Err(DataError::Invalid(format!(
            "{}: no bracketed frames (exposure_time and hdr_file_path) in the {} split; make them with `lucid gen SCENE --rig brackets`",
            names.join(", "),
            split.name()
        )));
    }
    Ok(out)
}

/// One batch of patches, each tensor `N×C×P×P` flattened.
pub struct Batch {
    /// Patches.
    pub n: usize,
    /// Side.
    pub patch: usize,
    /// Display values (3 channels).
    pub display: Vec<f32>,
    /// Linearised input (3).
    pub linear: Vec<f32>,
    /// Mask (1).
    pub mask: Vec<f32>,
    /// Truth (3).
    pub truth: Vec<f32>,
}

/// Draws `n` patches of side `patch`: a share `clipped_share` centred on a random clipped
/// pixel of a random image that has one, the rest anywhere.
pub fn sample_batch(images: &[ItmImage], n: usize, patch: usize, clipped_share: f32, rng: &mut Rng) -> Batch {
    let with_clipped: Vec<usize> = (0..images.len()).filter(|&k| !images[k].clipped.is_empty()).collect();
    let plane = patch * patch;
    let mut b = Batch {
        n,
        patch,
        display: vec![0.0; n * 3 * plane],
        linear: vec![0.0; n * 3 * plane],
        mask: vec![0.0; n * plane],
        truth: vec![0.0; n * 3 * plane],
    };
    for s in 0..n {
        let clipped = !with_clipped.is_empty() && rng.uniform() < clipped_share;
        let img = if clipped {
            &images[with_clipped[rng.below(with_clipped.len())]]
        } else {
            &images[rng.below(images.len())]
        };
        let (w, h) = (img.width, img.height);
        let (cx, cy) = if clipped {
            let i = img.clipped[rng.below(img.clipped.len())];
            (i % w, i / w)
        } else {
            (rng.below(w), rng.below(h))
        };
        let x0 = cx.saturating_sub(patch / 2).min(w - patch);
        let y0 = cy.saturating_sub(patch / 2).min(h - patch);
        let hw = w * h;
        for y in 0..patch {
            for x in 0..patch {
                let src = (y0 + y) * w + x0 + x;
                let dst = y * patch + x;
                b.mask[s * plane + dst] = img.mask[src];
                for c in 0..3 {
                    let o = (s * 3 + c) * plane + dst;
                    b.display[o] = img.display[c * hw + src];
                    b.linear[o] = img.linear[c * hw + src];
                    b.truth[o] = img.truth[c * hw + src];
                }
            }
        }
    }
    b
}

/// Checks that every image can hold a patch.
pub fn check_patch(images: &[ItmImage], patch: usize) -> Result<(), DataError> {
    match images.iter().find(|i| i.width < patch || i.height < patch) {
        Some(i) => Err(DataError::Invalid(format!(
            "{} is {}x{}, smaller than the training patch {patch} (set train.patch lower)",
            i.name, i.width, i.height
        ))),
        None => Ok(()),
    }
}
