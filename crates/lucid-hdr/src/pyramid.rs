//! Gaussian and Laplacian pyramids (Burt and Adelson 1983) of single-channel planes, with
//! the 5-tap binomial kernel and mirrored edges; Mertens' fusion blends in them.

use crate::blur::Plane;

const KERNEL: [f32; 5] = [1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0];

fn mirror(i: isize, n: usize) -> usize {
    let n = n as isize;
    let i = if i < 0 { -i } else { i };
    let i = if i >= n { 2 * (n - 1) - i } else { i };
    i.clamp(0, n - 1) as usize
}

/// Blur with the binomial kernel and keep every second pixel: `⌈w/2⌉ × ⌈h/2⌉`.
pub fn reduce(p: &Plane) -> Plane {
    let (w, h) = (p.width, p.height);
    let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
    // Horizontal then vertical, decimating as we go.
    let mut tmp = vec![0.0f32; nw * h];
    for y in 0..h {
        for x in 0..nw {
            let mut s = 0.0;
            for (k, t) in KERNEL.iter().enumerate() {
                s += t * p.data[y * w + mirror(2 * x as isize + k as isize - 2, w)];
            }
            tmp[y * nw + x] = s;
        }
    }
    let mut out = vec![0.0f32; nw * nh];
    for y in 0..nh {
        for x in 0..nw {
            let mut s = 0.0;
            for (k, t) in KERNEL.iter().enumerate() {
                s += t * tmp[mirror(2 * y as isize + k as isize - 2, h) * nw + x];
            }
            out[y * nw + x] = s;
        }
    }
    Plane { width: nw, height: nh, data: out }
}

/// Upsample to `width × height` (at most twice the size): zeros between samples, then the
/// binomial kernel doubled, so that constants stay constant.
pub fn expand(p: &Plane, width: usize, height: usize) -> Plane {
    // Each output pixel sums the kernel taps that land on even (source) positions.
    let tap = |out: usize, n_src: usize, n_out: usize| -> [(usize, f32); 3] {
        let mut taps = [(0usize, 0.0f32); 3];
        let mut k = 0;
        for (j, t) in KERNEL.iter().enumerate() {
            let pos = mirror(out as isize + j as isize - 2, n_out);
            if pos.is_multiple_of(2) && k < 3 {
                taps[k] = ((pos / 2).min(n_src - 1), 2.0 * t);
                k += 1;
            }
        }
        // Renormalise where mirroring dropped or doubled taps.
        let sum: f32 = taps.iter().map(|t| t.1).sum();
        if sum > 0.0 {
            for t in &mut taps {
                t.1 /= sum;
            }
        }
        taps
    };
    let mut tmp = vec![0.0f32; width * p.height];
    for x in 0..width {
        let taps = tap(x, p.width, width);
        for y in 0..p.height {
            tmp[y * width + x] = taps.iter().map(|&(i, t)| t * p.data[y * p.width + i]).sum();
        }
    }
    let mut out = vec![0.0f32; width * height];
    for y in 0..height {
        let taps = tap(y, p.height, height);
        for x in 0..width {
            out[y * width + x] = taps.iter().map(|&(i, t)| t * tmp[i * width + x]).sum();
        }
    }
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
    let g = gaussian_pyramid(p, levels);
    let mut out = Vec::with_capacity(levels);
    for l in 0..levels - 1 {
        let up = expand(&g[l + 1], g[l].width, g[l].height);
        let data = g[l].data.iter().zip(&up.data).map(|(a, b)| a - b).collect();
        out.push(Plane { width: g[l].width, height: g[l].height, data });
    }
    out.push(g[levels - 1].clone());
    out
}

/// Inverse of [`laplacian_pyramid`].
pub fn collapse(pyramid: &[Plane]) -> Plane {
    let mut acc = pyramid.last().expect("non-empty pyramid").clone();
    for level in pyramid.iter().rev().skip(1) {
        let up = expand(&acc, level.width, level.height);
        acc = Plane {
            width: level.width,
            height: level.height,
            data: level.data.iter().zip(&up.data).map(|(a, b)| a + b).collect(),
        };
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
}
