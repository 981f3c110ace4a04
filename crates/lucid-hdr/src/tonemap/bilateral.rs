//! The bilateral filter through a bilateral grid (Paris and Durand 2006; Chen et al. 2007):
//! values splatted into a coarse 3D grid over (x, y, value), blurred there, read back by
//! trilinear interpolation. Cost is linear in the pixels whatever the spatial σ, which a
//! direct filter at σ = 2% of a megapixel image (~20 px) is not. Written by hand: no
//! maintained crate offers a float bilateral filter.

use crate::blur::Plane;

/// Bilateral filter of `plane` with spatial σ `sigma_s` (pixels) and range σ `sigma_r`.
pub fn bilateral_grid(plane: &Plane, sigma_s: f32, sigma_r: f32) -> Plane {
    let (w, h) = (plane.width, plane.height);
    if w == 0 || h == 0 {
        return plane.clone();
    }
    let (lo, hi) = plane.data.iter().fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    const PAD: usize = 2;
    let gx = (w as f32 / sigma_s) as usize + 1 + 2 * PAD;
    let gy = (h as f32 / sigma_s) as usize + 1 + 2 * PAD;
    let gz = ((hi - lo) / sigma_r) as usize + 1 + 2 * PAD;
    let index = |x: usize, y: usize, z: usize| (z * gy + y) * gx + x;
    // Homogeneous (value, weight) pairs.
    let mut grid = vec![[0.0f32; 2]; gx * gy * gz];
    let coords = |x: usize, y: usize, v: f32| {
        (x as f32 / sigma_s + PAD as f32, y as f32 / sigma_s + PAD as f32, (v - lo) / sigma_r + PAD as f32)
    };
    for y in 0..h {
        for x in 0..w {
            let v = plane.data[y * w + x];
            let (cx, cy, cz) = coords(x, y, v);
            let cell = index(cx.round() as usize, cy.round() as usize, cz.round() as usize);
            grid[cell][0] += v;
            grid[cell][1] += 1.0;
        }
    }
    // Blur with [1 4 6 4 1]/16 (σ = 1 cell) along each axis.
    let dims = [gx, gy, gz];
    let strides = [1, gx, gx * gy];
    for axis in 0..3 {
        let mut out = vec![[0.0f32; 2]; grid.len()];
        for (i, o) in out.iter_mut().enumerate() {
            let pos = (i / strides[axis]) % dims[axis];
            let mut acc = [0.0f32; 2];
            for (k, t) in [1.0f32, 4.0, 6.0, 4.0, 1.0].iter().enumerate() {
                let p = pos as isize + k as isize - 2;
                if p < 0 || p >= dims[axis] as isize {
                    continue;
                }
                let j = (i as isize + (p - pos as isize) * strides[axis] as isize) as usize;
                acc[0] += t / 16.0 * grid[j][0];
                acc[1] += t / 16.0 * grid[j][1];
            }
            *o = acc;
        }
        grid = out;
    }
    // Slice.
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let v = plane.data[i];
            let (cx, cy, cz) = coords(x, y, v);
            let (x0, y0, z0) = (cx.floor() as usize, cy.floor() as usize, cz.floor() as usize);
            let (fx, fy, fz) = (cx - x0 as f32, cy - y0 as f32, cz - z0 as f32);
            let mut acc = [0.0f32; 2];
            for (dz, wz) in [(0, 1.0 - fz), (1, fz)] {
                for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                    for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                        let g = grid[index(x0 + dx, y0 + dy, z0 + dz)];
                        let wt = wx * wy * wz;
                        acc[0] += wt * g[0];
                        acc[1] += wt * g[1];
                    }
                }
            }
            if acc[1] > 0.0 { acc[0] / acc[1] } else { v }
        })
        .collect();
    Plane { width: w, height: h, data }
}
