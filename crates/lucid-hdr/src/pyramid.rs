//! Gaussian and Laplacian pyramids (Burt and Adelson 1983) of single-channel planes, with
//! the 5-tap binomial kernel and mirrored edges; Mertens' fusion blends in them.
//!
//! Each pass runs over rows in parallel, the edge taps (where mirroring applies) are worked
//! out once per pass rather than per pixel, and the vertical passes combine whole rows so
//! that their inner loops vectorise: the pyramids are most of the fusion's time.

use rayon::prelude::*;

use crate::blur::Plane;

const KERNEL: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let i = if i < 0 { -i } else { i };
    let i = if i >= n { 2 * (n - 1) - i } else { i };
    i.clamp(0, n - 1) as usize
}

/// Source indices of the five taps of output `out` of a reduction along an axis of `n`.
fn reduce_taps(out: usize, n: usize) -> [usize; 5] {
    std::array::from_fn(|k| mirror(2 * out as isize + k as isize - 2, n))
}

/// Blur with the binomial kernel and keep every second pixel: `⌈w/2⌉ × ⌈h/2⌉`.
pub fn reduce(p: &Plane) -> Plane {
    let (w, h) = (p.width, p.height);
    let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
    // Horizontal then vertical, decimating as we go.
    let columns: Vec<[usize; 5]> = (0..nw).map(|x| reduce_taps(x, w)).collect();
    let mut tmp = vec![0.0f32; nw * h];
    tmp.par_chunks_mut(nw.max(1)).zip(p.data.par_chunks(w.max(1))).for_each(|(dst, src)| {
        for (d, taps) in dst.iter_mut().zip(&columns) {
            *d = KERNEL.iter().zip(taps).map(|(t, &i)| t * src[i]).fold(0.0, |s, v| s + v);
        }
    });
    let mut out = vec![0.0f32; nw * nh];
    out.par_chunks_mut(nw.max(1)).enumerate().for_each(|(y, dst)| {
        let rows = reduce_taps(y, h).map(|r| &tmp[r * nw..(r + 1) * nw]);
        for (x, d) in dst.iter_mut().enumerate() {
            // Summed in kernel order, as a pixel-at-a-time loop would.
            let mut s = 0.0;
            for (t, row) in KERNEL.iter().zip(&rows) {
                s += t * row[x];
            }
            *d = s;
        }
    });
    Plane { width: nw, height: nh, data: out }
}

/// Source indices and weights of output `out` of an expansion from `n_src` to `n_out`
/// samples: the kernel taps (doubled) that land on even, source, positions, renormalised
/// where mirroring dropped or doubled some.
fn expand_taps(out: usize, n_src: usize, n_out: usize) -> [(usize, f32); 3] {
    let mut taps = [(0usize, 0.0f32); 3];
    let mut k = 0;
    for (j, t) in KERNEL.iter().enumerate() {
        let pos = mirror(out as isize + j as isize - 2, n_out);
        if pos.is_multiple_of(2) && k < 3 {
            taps[k] = ((pos / 2).min(n_src - 1), 2.0 * t);
            k += 1;
        }
    }
    let sum: f32 = taps.iter().map(|t| t.1).sum();
    if sum > 0.0 {
        for t in &mut taps {
            t.1 /= sum;
        }
    }
    taps
}

/// Upsample to `width × height` (at most twice the size): zeros between samples, then the
/// binomial kernel doubled, so that constants stay constant.
pub fn expand(p: &Plane, width: usize, height: usize) -> Plane {
    let columns: Vec<[(usize, f32); 3]> = (0..width).map(|x| expand_taps(x, p.width, width)).collect();
    let mut tmp = vec![0.0f32; width * p.height];
    tmp.par_chunks_mut(width.max(1)).zip(p.data.par_chunks(p.width.max(1))).for_each(|(dst, src)| {
        for (d, taps) in dst.iter_mut().zip(&columns) {
            *d = taps.iter().map(|&(i, t)| t * src[i]).fold(0.0, |s, v| s + v);
        }
    });
    let mut out = vec![0.0f32; width * height];
    out.par_chunks_mut(width.max(1)).enumerate().for_each(|(y, dst)| {
        let taps = expand_taps(y, p.height, height).map(|(i, t)| (&tmp[i * width..(i + 1) * width], t));
        for (x, d) in dst.iter_mut().enumerate() {
            let mut s = 0.0;
            for (row, t) in &taps {
                s += t * row[x];
            }
            *d = s;
        }
    });
    Plane { width, height, data: out }
}

/// Gaussian pyramid with `levels` levels (the first is the input).
pub fn gaussian_pyramid(p: &Plane, levels: usize) -> Vec<Plane> {
    let mut out = vec![p.clone()];
    while out.len() < levels {
        let next = reduce(out.last().expect("non-empty"));
        out.push(next);
    }
    out
}

/// Laplacian pyramid: band-pass levels, then the coarsest Gaussian level.
pub fn laplacian_pyramid(p: &Plane, levels: usize) -> Vec<Plane> {
    let mut g = gaussian_pyramid(p, levels);
    let mut out = Vec::with_capacity(levels);
    for l in 0..levels - 1 {
        let mut band = expand(&g[l + 1], g[l].width, g[l].height);
        band.data.par_iter_mut().zip(&g[l].data).for_each(|(up, fine)| *up = fine - *up);
        out.push(band);
    }
    out.push(g.pop().expect("at least one level"));
    out
}

/// Inverse of [`laplacian_pyramid`].
pub fn collapse(pyramid: &[Plane]) -> Plane {
    let mut acc = pyramid.last().expect("non-empty pyramid").clone();
    for level in pyramid.iter().rev().skip(1) {
        let mut up = expand(&acc, level.width, level.height);
        up.data.par_iter_mut().zip(&level.data).for_each(|(a, b)| *a += b);
        acc = up;
    }
    acc
}

/// Levels for a `w × h` image: down to about 8 pixels on the short side.
pub fn levels_for(w: usize, h: usize) -> usize {
    let mut n = 1;
    let mut s = w.min(h);
    while s > 8 {
        s = s.div_ceil(2);
        n += 1;
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laplacian_pyramid_reconstructs_exactly() {
        let p = Plane::from_fn(45, 30, |i| ((i * 7919) % 113) as f32 / 113.0);
        let levels = levels_for(45, 30);
        let back = collapse(&laplacian_pyramid(&p, levels));
        let err = p.data.iter().zip(&back.data).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
        assert!(err < 1e-5, "{err}");
    }

    #[test]
    fn expand_keeps_constants() {
        let p = Plane::filled(7, 5, 0.3);
        let e = expand(&p, 13, 10);
        assert!(e.data.iter().all(|v| (v - 0.3).abs() < 1e-6));
    }

    /// The row-parallel passes compute exactly what the textbook pixel-at-a-time definitions
    /// do (mirrored taps per pixel), at odd and even sizes.
    #[test]
    fn passes_match_the_pixel_at_a_time_definitions() {
        for (w, h) in [(1, 1), (2, 3), (17, 9), (64, 33)] {
            let p = Plane::from_fn(w, h, |i| ((i * 7919) % 113) as f32 / 113.0);
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let at = |x: isize, y: isize| p.data[mirror(y, h) * w + mirror(x, w)];
            let reduced = reduce(&p);
            for y in 0..nh {
                for x in 0..nw {
                    // Separable: horizontal sums first, then the vertical combination.
                    let row = |yy: isize| {
                        KERNEL.iter().enumerate().fold(0.0, |s, (k, t)| s + t * at(2 * x as isize + k as isize - 2, yy))
                    };
                    let want = KERNEL
                        .iter()
                        .enumerate()
                        .fold(0.0, |s, (k, t)| s + t * row(mirror(2 * y as isize + k as isize - 2, h) as isize));
                    assert_eq!(reduced.at(x, y), want, "reduce {w}x{h} at ({x}, {y})");
                }
            }
            let (ew, eh) = (2 * w, 2 * h);
            let expanded = expand(&p, ew, eh);
            for y in 0..eh {
                for x in 0..ew {
                    let row = |yy: usize| expand_taps(x, w, ew).iter().fold(0.0, |s, &(i, t)| s + t * p.at(i, yy));
                    let want = expand_taps(y, h, eh).iter().fold(0.0, |s, &(i, t)| s + t * row(i));
                    assert_eq!(expanded.at(x, y), want, "expand {w}x{h} at ({x}, {y})");
                }
            }
        }
    }
}
