//! Moving images between a distorted camera and pinhole ones. A rasterizer projects through a
//! pinhole only, so 3DGS trains on undistorted images (as the reference implementation does
//! after COLMAP's undistorter) and is scored on the original, distorted ones by rendering a
//! pinhole view wide enough to cover them and warping it back through the lens.

use glam::Vec2;
use rayon::prelude::*;

use crate::camera::Intrinsics;

/// Border samples per pixel of edge when tracing the image's outline through the lens.
const OUTLINE_SAMPLES_PER_PIXEL: usize = 2;

/// A rectangle in normalised pinhole coordinates (x right, y down): `[x0, y0, x1, y1]`.
pub type NormalisedRect = [f32; 4];

/// What a distorted image sees, in normalised pinhole coordinates: the largest axis-aligned
/// rectangle every point of which the image holds (`inner`), and the smallest that holds the
/// whole image (`outer`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UndistortedExtent {
    /// Inside the image everywhere.
    pub inner: NormalisedRect,
    /// Covers the image.
    pub outer: NormalisedRect,
}

/// Traces the outline of `k`'s image through the inverse of its lens.
pub fn undistorted_extent(k: &Intrinsics) -> UndistortedExtent {
    let (w, h) = (k.width as f32, k.height as f32);
    let normalised = |px: f32, py: f32| k.distortion.undistort(Vec2::new((px - k.cx) / k.fx, (py - k.cy) / k.fy));
    let along = |n: u32| {
        (0..=(n as usize * OUTLINE_SAMPLES_PER_PIXEL)).map(move |i| i as f32 / OUTLINE_SAMPLES_PER_PIXEL as f32)
    };
    let left: Vec<Vec2> = along(k.height).map(|y| normalised(0.0, y)).collect();
    let right: Vec<Vec2> = along(k.height).map(|y| normalised(w, y)).collect();
    let top: Vec<Vec2> = along(k.width).map(|x| normalised(x, 0.0)).collect();
    let bottom: Vec<Vec2> = along(k.width).map(|x| normalised(x, h)).collect();
    let max = |v: &[Vec2], axis: usize| v.iter().map(|p| p[axis]).fold(f32::MIN, f32::max);
    let min = |v: &[Vec2], axis: usize| v.iter().map(|p| p[axis]).fold(f32::MAX, f32::min);
    let all: Vec<Vec2> = [&left, &right, &top, &bottom].into_iter().flatten().copied().collect();
    UndistortedExtent {
        inner: [max(&left, 0), max(&top, 1), min(&right, 0), min(&bottom, 1)],
        outer: [min(&all, 0), min(&all, 1), max(&all, 0), max(&all, 1)],
    }
}

/// The pinhole camera with `k`'s focal lengths (so the centre keeps its pixel density) whose
/// image spans `rect`: whole pixels inside it when `inside`, else whole pixels covering it.
pub fn pinhole_spanning(k: &Intrinsics, rect: NormalisedRect, inside: bool) -> Intrinsics {
    let [x0, y0, x1, y1] = rect;
    let round = |v: f32| if inside { v.floor() } else { v.ceil() };
    let width = round((x1 - x0) * k.fx).max(1.0);
    let height = round((y1 - y0) * k.fy).max(1.0);
    // Centre the whole-pixel image on the rectangle.
    let cx = -0.5 * (x0 + x1) * k.fx + 0.5 * width;
    let cy = -0.5 * (y0 + y1) * k.fy + 0.5 * height;
    Intrinsics::pinhole(width as u32, height as u32, k.fx, k.fy, cx, cy)
}

/// The pinhole camera whose every pixel `k`'s image holds: the training camera of 3DGS.
pub fn inner_pinhole(k: &Intrinsics) -> Intrinsics {
    if k.distortion.is_pinhole() {
        return *k;
    }
    pinhole_spanning(k, undistorted_extent(k).inner, true)
}

/// The pinhole camera that sees all of `k`'s image: what a rasterizer renders before the
/// render is warped into `k`.
pub fn outer_pinhole(k: &Intrinsics) -> Intrinsics {
    if k.distortion.is_pinhole() {
        return *k;
    }
    pinhole_spanning(k, undistorted_extent(k).outer, false)
}

/// Resamples `pixels`, taken by camera `from`, into the image camera `to` (same pose) would
/// take: each pixel's ray goes through `to`'s lens inverse and `from`'s lens, and the source is
/// read bilinearly (clamped at its border). `C` channels per pixel.
pub fn resample<const C: usize>(pixels: &[[f32; C]], from: &Intrinsics, to: &Intrinsics) -> Vec<[f32; C]> {
    let (sw, sh) = (from.width as usize, from.height as usize);
    assert_eq!(pixels.len(), sw * sh, "the source image has the size of its camera");
    let (w, h) = (to.width as usize, to.height as usize);
    let mut out = vec![[0.0f32; C]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, o) in row.iter_mut().enumerate() {
            let d = Vec2::new((i as f32 + 0.5 - to.cx) / to.fx, (j as f32 + 0.5 - to.cy) / to.fy);
            let u = to.distortion.undistort(d);
            let s = from.distortion.distort(u);
            // Pixel centres sit at half-integers.
            let sx = (from.cx + from.fx * s.x - 0.5).clamp(0.0, (sw - 1) as f32);
            let sy = (from.cy + from.fy * s.y - 0.5).clamp(0.0, (sh - 1) as f32);
            let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(sw - 1), (y0 + 1).min(sh - 1));
            let (fx, fy) = (sx - x0 as f32, sy - y0 as f32);
            let at = |x: usize, y: usize| &pixels[y * sw + x];
            for (c, v) in o.iter_mut().enumerate() {
                let top = at(x0, y0)[c] * (1.0 - fx) + at(x1, y0)[c] * fx;
                let bottom = at(x0, y1)[c] * (1.0 - fx) + at(x1, y1)[c] * fx;
                *v = top * (1.0 - fy) + bottom * fy;
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::LensDistortion;

    fn distorted() -> Intrinsics {
        Intrinsics {
            distortion: LensDistortion::opencv(-0.2, 0.05, 0.001, -0.0005),
            ..Intrinsics::pinhole(160, 120, 140.0, 138.0, 81.0, 59.0)
        }
    }

    /// A smooth pattern, defined on the pinhole plane, that both cameras photograph.
    fn pattern(u: Vec2) -> [f32; 1] {
        [(3.0 * u.x).sin() * (2.0 * u.y).cos() + u.x * u.y]
    }

    fn photograph(k: &Intrinsics) -> Vec<[f32; 1]> {
        (0..k.height)
            .flat_map(|j| (0..k.width).map(move |i| (i, j)))
            .map(|(i, j)| {
                let d = Vec2::new((i as f32 + 0.5 - k.cx) / k.fx, (j as f32 + 0.5 - k.cy) / k.fy);
                pattern(k.distortion.undistort(d))
            })
            .collect()
    }

    #[test]
    fn the_inner_pinhole_lies_inside_the_image_and_the_outer_covers_it() {
        let k = distorted();
        let (inner, outer) = (inner_pinhole(&k), outer_pinhole(&k));
        // A barrel lens squeezes the periphery: undistorted, the image's edges bow outwards
        // past the pinhole frame, its corners farthest.
        assert!(k.width < inner.width && inner.width < outer.width, "{} < {} < {}", k.width, inner.width, outer.width);
        // Every inner pixel's ray lands inside the distorted image.
        for (i, j) in [(0, 0), (inner.width - 1, 0), (0, inner.height - 1), (inner.width - 1, inner.height - 1)] {
            let u = Vec2::new((i as f32 + 0.5 - inner.cx) / inner.fx, (j as f32 + 0.5 - inner.cy) / inner.fy);
            let d = k.distortion.distort(u);
            let p = Vec2::new(k.cx + k.fx * d.x, k.cy + k.fy * d.y);
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x <= k.width as f32 && p.y <= k.height as f32, "{p}");
        }
        // Every distorted pixel's ray lands inside the outer pinhole image.
        for (i, j) in [(0, 0), (k.width - 1, 0), (k.width / 2, k.height - 1), (0, k.height / 2)] {
            let d = Vec2::new((i as f32 + 0.5 - k.cx) / k.fx, (j as f32 + 0.5 - k.cy) / k.fy);
            let u = k.distortion.undistort(d);
            let p = Vec2::new(outer.cx + outer.fx * u.x, outer.cy + outer.fy * u.y);
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x <= outer.width as f32 && p.y <= outer.height as f32, "{p}");
        }
    }

    #[test]
    fn resampling_through_the_lens_matches_a_direct_photograph() {
        let k = distorted();
        let original = photograph(&k);
        // Undistorting gives what a pinhole would have photographed ...
        let inner = inner_pinhole(&k);
        let undistorted = resample(&original, &k, &inner);
        let want = photograph(&inner);
        let worst = undistorted.iter().zip(&want).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0, f32::max);
        assert!(worst < 0.02, "undistorted: worst error {worst}");
        // ... and a wide pinhole photograph warped back gives the distorted one.
        let outer = outer_pinhole(&k);
        let back = resample(&photograph(&outer), &outer, &k);
        let worst = back.iter().zip(&original).map(|(a, b)| (a[0] - b[0]).abs()).fold(0.0, f32::max);
        assert!(worst < 0.02, "redistorted: worst error {worst}");
    }

    #[test]
    fn a_pinhole_camera_resamples_to_itself() {
        let k = Intrinsics::pinhole(32, 24, 30.0, 30.0, 16.0, 12.0);
        assert_eq!(inner_pinhole(&k), k);
        let image = photograph(&k);
        let same = resample(&image, &k, &k);
        assert!(same.iter().zip(&image).all(|(a, b)| (a[0] - b[0]).abs() < 1e-6));
    }
}
