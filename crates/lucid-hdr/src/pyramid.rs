//! Gaussian and Laplacian pyramids (Burt and Adelson 1983) of single-channel planes with the
//! 5-tap binomial kernel, at OpenCV's edges (`pyrDown`/`pyrUp`), so that Mertens' fusion
//! reproduces `cv::MergeMertens` rather than merely resembling it: reduction mirrors without
//! repeating the edge sample (`BORDER_REFLECT_101`); expansion mirrors at the start and
//! repeats the last sample at the end, and an odd-sized expansion is the even one cut short.
//!
//! Each pass runs over rows in parallel with the interior written as plain strided loops (the
//! edges apart), and expansion hands each output row to a caller that combines it on the spot
//! ([`expand_rows`]): a Laplacian band is never stored, only added into where it goes.

use rayon::prelude::*;

use crate::blur::Plane;

const KERNEL: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

/// `BORDER_REFLECT_101`: `-1 → 1`, `n → n − 2`.
pub(crate) fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let i = if i < 0 { -i } else { i };
    let i = if i >= n { 2 * (n - 1) - i } else { i };
    i.clamp(0, n - 1) as usize
}

/// One row blurred and decimated: `dst[x] = Σ_k KERNEL[k]·src[2x + k − 2]`, mirrored.
fn reduce_row(src: &[f32], dst: &mut [f32]) {
    let n = src.len();
    let edge = |x: usize| {
        KERNEL.iter().enumerate().fold(0.0, |s, (k, t)| s + t * src[mirror(2 * x as isize + k as isize - 2, n)])
    };
    // Interior outputs read 2x−2 ..= 2x+2 without mirroring.
    let last_interior = (n.saturating_sub(3)) / 2;
    for (x, d) in dst.iter_mut().enumerate() {
        if x == 0 || x > last_interior {
            *d = edge(x);
        } else {
            let s = &src[2 * x - 2..2 * x + 3];
            *d = KERNEL[0] * s[0] + KERNEL[1] * s[1] + KERNEL[2] * s[2] + KERNEL[3] * s[3] + KERNEL[4] * s[4];
        }
    }
}

/// Blur with the binomial kernel and keep every second pixel: `⌈w/2⌉ × ⌈h/2⌉`.
pub fn reduce(p: &Plane) -> Plane {
    let mut out = Plane::filled(p.width.div_ceil(2), p.height.div_ceil(2), 0.0);
    reduce_into(p, &mut out);
    out
}

/// [`reduce`] into a plane of the reduced size. Each output row combines its five source rows
/// first (a vectorised pass over whole rows) and then decimates that one row, so no
/// intermediate plane is allocated.
pub fn reduce_into(p: &Plane, out: &mut Plane) {
    let (w, h) = (p.width, p.height);
    assert!(out.width == w.div_ceil(2) && out.height == h.div_ceil(2), "reduce_into: wrong output size");
    out.data.par_chunks_mut(out.width.max(1)).enumerate().for_each_init(
        || vec![0.0f32; w],
        |column, (y, dst)| {
            let rows: [&[f32]; 5] = std::array::from_fn(|k| mirror(2 * y as isize + k as isize - 2, h))
                .map(|r| &p.data[r * w..(r + 1) * w]);
            for (x, v) in column.iter_mut().enumerate() {
                *v = KERNEL[0] * rows[0][x]
                    + KERNEL[1] * rows[1][x]
                    + KERNEL[2] * rows[2][x]
                    + KERNEL[3] * rows[3][x]
                    + KERNEL[4] * rows[4][x];
            }
            reduce_row(column, dst);
        },
    );
}

/// Source indices and weights of output `out` of an expansion of `n` samples (OpenCV's
/// `pyrUp`): even outputs `(s[i−1] + 6 s[i] + s[i+1]) / 8`, odd ones `(s[i] + s[i+1]) / 2`,
/// with `s[−1] = s[1]` and `s[n] = s[n−1]`.
fn expand_taps(out: usize, n: usize) -> [(usize, f32); 3] {
    let i = out / 2;
    let next = (i + 1).min(n - 1);
    if out.is_multiple_of(2) {
        let prev = if i == 0 { 1.min(n - 1) } else { i - 1 };
        [(prev, 0.125), (i, 0.75), (next, 0.125)]
    } else {
        [(i, 0.5), (next, 0.5), (i, 0.0)]
    }
}

/// One row upsampled to `dst.len()` (`2n` or `2n − 1`) samples.
fn expand_row(src: &[f32], dst: &mut [f32]) {
    let n = src.len();
    let edge = |o: usize| expand_taps(o, n).iter().fold(0.0, |s, &(i, t)| s + t * src[i]);
    let interior_end = 2 * n.saturating_sub(1);
    for (o, d) in dst.iter_mut().enumerate().take(2) {
        *d = edge(o);
    }
    if interior_end > 2 {
        // Outputs 2 ..< 2(n−1) in pairs: both neighbours exist.
        for (pair, w) in dst[2..interior_end].chunks_exact_mut(2).zip(src.windows(3)) {
            pair[0] = 0.125 * w[0] + 0.75 * w[1] + 0.125 * w[2];
            pair[1] = 0.5 * w[1] + 0.5 * w[2];
        }
    }
    let tail = interior_end.max(2);
    for (o, d) in dst.iter_mut().enumerate().skip(tail) {
        *d = edge(o);
    }
}

/// Expands `p` to `width × height` (each `2n` or `2n − 1` of the source's) and calls
/// `combine(y, out_row, expanded_row)` for every row of a `width × height` target, rows in
/// parallel: the expansion itself is never stored. Each output row combines its source rows
/// first and then upsamples that one row.
pub fn expand_rows(
    p: &Plane,
    width: usize,
    height: usize,
    target: &mut [f32],
    combine: impl Fn(usize, &mut [f32], &[f32]) + Sync,
) {
    assert!(width.div_ceil(2) == p.width && height.div_ceil(2) == p.height, "expand_rows: wrong sizes");
    assert_eq!(target.len(), width * height, "expand_rows: wrong target size");
    let sw = p.width;
    target.par_chunks_mut(width.max(1)).enumerate().for_each_init(
        || (vec![0.0f32; sw], vec![0.0f32; width]),
        |(column, row), (y, dst)| {
            let [(a, ta), (b, tb), (c, tc)] = expand_taps(y, p.height).map(|(i, t)| (&p.data[i * sw..(i + 1) * sw], t));
            for (x, v) in column.iter_mut().enumerate() {
                *v = ta * a[x] + tb * b[x] + tc * c[x];
            }
            expand_row(column, row);
            combine(y, dst, row);
        },
    );
}

/// Upsample to `width × height` (each `2n` or `2n − 1` of the source's).
pub fn expand(p: &Plane, width: usize, height: usize) -> Plane {
    let mut data = vec![0.0f32; width * height];
    expand_rows(p, width, height, &mut data, |_, dst, row| dst.copy_from_slice(row));
    Plane { width, height, data }
}

/// Gaussian pyramid with `levels` levels (the first is the input).
pub fn gaussian_pyramid(p: Plane, levels: usize) -> Vec<Plane> {
    let mut out = Vec::with_capacity(levels);
    out.push(p);
    while out.len() < levels {
        let next = reduce(out.last().expect("non-empty"));
        out.push(next);
    }
    out
}

/// Fills levels `1..` of a pyramid of planes already sized by [`pyramid_sizes`] from level 0:
/// buffers are reused from frame to frame instead of faulting in fresh memory each time.
pub fn fill_gaussian_pyramid(pyramid: &mut [Plane]) {
    for l in 1..pyramid.len() {
        let (fine, coarse) = pyramid.split_at_mut(l);
        reduce_into(&fine[l - 1], &mut coarse[0]);
    }
}

/// Width and height of each of `levels` levels of a pyramid of a `w × h` plane.
pub fn pyramid_sizes(w: usize, h: usize, levels: usize) -> Vec<(usize, usize)> {
    std::iter::successors(Some((w, h)), |&(a, b)| Some((a.div_ceil(2), b.div_ceil(2)))).take(levels).collect()
}

/// Laplacian pyramid: band-pass levels, then the coarsest Gaussian level.
pub fn laplacian_pyramid(p: Plane, levels: usize) -> Vec<Plane> {
    let mut g = gaussian_pyramid(p, levels);
    for l in 0..levels - 1 {
        let (fine, coarse) = g.split_at_mut(l + 1);
        let fine = &mut fine[l];
        expand_rows(&coarse[0], fine.width, fine.height, &mut fine.data, |_, dst, up| {
            for (d, u) in dst.iter_mut().zip(up) {
                *d -= u;
            }
        });
    }
    g
}

/// Inverse of [`laplacian_pyramid`], in place: the finest level ends up holding the image.
pub fn collapse(mut pyramid: Vec<Plane>) -> Plane {
    for l in (1..pyramid.len()).rev() {
        let (fine, coarse) = pyramid.split_at_mut(l);
        let fine = &mut fine[l - 1];
        expand_rows(&coarse[0], fine.width, fine.height, &mut fine.data, |_, dst, up| {
            for (d, u) in dst.iter_mut().zip(up) {
                *d += u;
            }
        });
    }
    pyramid.swap_remove(0)
}

/// Levels for a `w × h` image as OpenCV's `MergeMertens` chooses them: `⌊log₂ min(w, h)⌋`
/// reductions, down to one or two pixels on the short side.
pub fn levels_for(w: usize, h: usize) -> usize {
    w.min(h).max(1).ilog2() as usize + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(w: usize, h: usize) -> Plane {
        Plane::from_fn(w, h, |i| ((i * 7919) % 113) as f32 / 113.0)
    }

    #[test]
    fn laplacian_pyramid_reconstructs_exactly() {
        for (w, h) in [(45, 30), (64, 64), (3, 17)] {
            let p = texture(w, h);
            let back = collapse(laplacian_pyramid(p.clone(), levels_for(w, h)));
            let err = p.data.iter().zip(&back.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(err < 1e-5, "{w}x{h}: {err}");
        }
    }

    #[test]
    fn expand_keeps_constants() {
        let p = Plane::filled(7, 5, 0.3);
        let e = expand(&p, 13, 10);
        assert!(e.data.iter().all(|v| (v - 0.3).abs() < 1e-6));
    }

    /// The linear map of one expansion (output × source, times 8), as OpenCV 5.1's `pyrUp`
    /// computes it: found by expanding unit impulses with cv2 (`scripts/compare-opencv-mertens.py`
    /// checks the whole fusion).
    #[test]
    fn expansion_weights_are_opencvs() {
        let opencv_5_to_9 = [
            [6, 2, 0, 0, 0],
            [4, 4, 0, 0, 0],
            [1, 6, 1, 0, 0],
            [0, 4, 4, 0, 0],
            [0, 1, 6, 1, 0],
            [0, 0, 4, 4, 0],
            [0, 0, 1, 6, 1],
            [0, 0, 0, 4, 4],
            [0, 0, 0, 1, 7],
        ];
        let opencv_4_to_8_last = [[0, 0, 1, 7], [0, 0, 0, 8]];
        let weights = |n: usize, m: usize| -> Vec<Vec<f32>> {
            (0..m)
                .map(|o| {
                    let mut row = vec![0.0; n];
                    for i in 0..n {
                        let mut impulse = vec![0.0; n];
                        impulse[i] = 1.0;
                        let mut out = vec![0.0; m];
                        expand_row(&impulse, &mut out);
                        row[i] = 8.0 * out[o];
                    }
                    row
                })
                .collect()
        };
        let got = weights(5, 9);
        for (o, want) in opencv_5_to_9.iter().enumerate() {
            assert_eq!(got[o], want.map(|v| v as f32).to_vec(), "5→9, output {o}");
        }
        let got = weights(4, 8);
        for (o, want) in opencv_4_to_8_last.iter().enumerate() {
            assert_eq!(got[6 + o], want.map(|v| v as f32).to_vec(), "4→8, output {}", 6 + o);
        }
        // Vertically the same rule: a plane expanded is the rows expanded.
        let p = texture(5, 5);
        let e = expand(&p, 9, 9);
        let t = expand(&Plane { width: 5, height: 5, data: transpose(&p.data, 5, 5) }, 9, 9);
        let back = transpose(&t.data, 9, 9);
        let err = e.data.iter().zip(&back).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-6, "expansion is not the same along both axes: {err}");
    }

    fn transpose(d: &[f32], w: usize, h: usize) -> Vec<f32> {
        (0..w * h).map(|i| d[(i % h) * w + i / h]).collect()
    }

    /// Reduction is OpenCV's `pyrDown` (`BORDER_REFLECT_101`): the strided interior equals the
    /// mirrored definition everywhere, at odd and even sizes.
    #[test]
    fn reduction_is_the_mirrored_binomial_filter() {
        for (w, h) in [(1, 1), (2, 3), (9, 10), (17, 9), (64, 33)] {
            let p = texture(w, h);
            let at = |x: isize, y: isize| p.data[mirror(y, h) * w + mirror(x, w)];
            let reduced = reduce(&p);
            for y in 0..h.div_ceil(2) {
                for x in 0..w.div_ceil(2) {
                    let want: f32 = (0..5)
                        .flat_map(|j| (0..5).map(move |k| (j, k)))
                        .map(|(j, k)| {
                            KERNEL[j] * KERNEL[k] * at(2 * x as isize + k as isize - 2, 2 * y as isize + j as isize - 2)
                        })
                        .sum();
                    assert!((reduced.at(x, y) - want).abs() < 1e-6, "{w}x{h} at ({x}, {y})");
                }
            }
        }
        // OpenCV's weights at the end of a row of 9 (times 16): taps fold back onto 6 and 7.
        let mut impulse_row = |i: usize| {
            let mut src = vec![0.0; 9];
            src[i] = 1.0;
            let mut dst = vec![0.0; 5];
            reduce_row(&src, &mut dst);
            16.0 * dst[4]
        };
        assert_eq!([6, 7, 8].map(&mut impulse_row), [2.0, 8.0, 6.0]);
    }

    #[test]
    fn levels_follow_opencv() {
        assert_eq!(levels_for(1000, 1000), 10);
        assert_eq!(levels_for(64, 100), 7);
        assert_eq!(levels_for(53, 37), 6);
        assert_eq!(levels_for(1, 5), 1);
    }
}
