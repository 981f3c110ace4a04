//! The radiance field of instant-ngp as one fused kernel: hash-grid encoding → density MLP
//! (the first output is log-density, the rest geometry features) → with the spherical-harmonic
//! encoding of the view direction → colour MLP → RGB. Plain Rust over slices, parallel over
//! chunks of samples with rayon, matrix products on `gemm`.
//!
//! Fused by hand because burn's per-layer ops on the CPU spend more time allocating and
//! copying `S×64` activations than multiplying them (`lucid bench nerf` and the README's NeRF
//! section give the measurements); the
//! weights are still burn parameters (a table and one flat MLP vector).

pub mod mlp;

use lucid_scene::simd::wide;
use rayon::prelude::*;

use crate::encoding::hash_grid::{HashGridConfig, HashGridLayout};
use crate::encoding::spherical_harmonics::{self, sh_encode};
use mlp::{MlpShape, View, matmul, matmul_raw};

/// Largest log-density passed to `exp` (and the clamp of its gradient): `exp(15) ≈ 3·10⁶`.
const MAX_LOG_DENSITY: f32 = 15.0;

/// Samples per parallel task: rows of every matrix product.
const CHUNK: usize = 256;

/// Chunks per task of the backward pass (and per partial sum of the weight gradients).
const GROUP_CHUNKS: usize = 8;

/// Hyper-parameters of the field.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FieldConfig {
    /// The position encoding.
    pub grid: HashGridConfig,
    /// Width of every hidden layer.
    pub hidden: usize,
    /// Outputs of the density MLP (log-density first, then geometry features).
    pub geometry_features: usize,
    /// Hidden layers of the density MLP.
    pub density_hidden_layers: usize,
    /// Hidden layers of the colour MLP.
    pub colour_hidden_layers: usize,
    /// Bands of the view direction's spherical-harmonic encoding (instant-ngp: 4, that is
    /// 16 coefficients).
    pub direction_degree: usize,
}

impl Default for FieldConfig {
    /// instant-ngp's NeRF (64 wide, 16 geometry features, 1 + 2 hidden layers) with a third
    /// hidden layer in the colour MLP: on the benchmark sets' validation views at 600 s it
    /// gained 0.1 dB on both for 6–10 % fewer steps (README).
    fn default() -> Self {
        Self {
            grid: HashGridConfig::default(),
            hidden: 64,
            geometry_features: 16,
            density_hidden_layers: 1,
            colour_hidden_layers: 3,
            direction_degree: 4,
        }
    }
}

impl FieldConfig {
    /// Checks the values; the message names the wrong one.
    pub fn validate(&self) -> Result<(), String> {
        self.grid.validate()?;
        if !(1..=512).contains(&self.hidden) {
            return Err(format!("hidden must be in 1..=512, got {}", self.hidden));
        }
        if !(1..=256).contains(&self.geometry_features) {
            return Err(format!("geometry_features must be in 1..=256, got {}", self.geometry_features));
        }
        if self.density_hidden_layers > 8 || self.colour_hidden_layers > 8 {
            return Err("at most 8 hidden layers per MLP".into());
        }
        if !(1..=spherical_harmonics::MAX_DEGREE).contains(&self.direction_degree) {
            return Err(format!(
                "direction_degree must be in 1..={}, got {}",
                spherical_harmonics::MAX_DEGREE,
                self.direction_degree
            ));
        }
        Ok(())
    }

    /// Where everything lives.
    pub fn layout(&self) -> FieldLayout {
        let grid = self.grid.layout();
        let (h, g) = (self.hidden, self.geometry_features);
        let mut dims = vec![grid.output_dim()];
        dims.extend(std::iter::repeat_n(h, self.density_hidden_layers));
        dims.push(g);
        let density = MlpShape::new(dims, 0);
        let mut dims = vec![g + spherical_harmonics::coefficients(self.direction_degree)];
        dims.extend(std::iter::repeat_n(h, self.colour_hidden_layers));
        dims.push(3);
        let colour = MlpShape::new(dims, density.end());
        FieldLayout::new(grid, density, colour)
    }
}

/// The table and MLP layouts, and where each activation sits in a saved row.
#[derive(Clone, Debug)]
pub struct FieldLayout {
    /// The hash grid.
    pub grid: HashGridLayout,
    /// Density MLP (weights from 0).
    pub density: MlpShape,
    /// Colour MLP (weights after the density MLP's).
    pub colour: MlpShape,
    /// Start of each density layer's output in a saved row (the encoding is at 0).
    density_out: Vec<usize>,
    /// Start of each colour layer's output; its input (geometry features + SH) is at `colour_in`.
    colour_out: Vec<usize>,
    colour_in: usize,
    /// `σ, r, g, b` after activation.
    result: usize,
    stride: usize,
}

impl FieldLayout {
    fn new(grid: HashGridLayout, density: MlpShape, colour: MlpShape) -> Self {
        let mut at = grid.output_dim();
        let mut density_out = Vec::new();
        for i in 0..density.layers() - 1 {
            density_out.push(at);
            at += density.layer(i).1;
        }
        let colour_in = at;
        density_out.push(colour_in);
        at += colour.input();
        let mut colour_out = Vec::new();
        for i in 0..colour.layers() - 1 {
            colour_out.push(at);
            at += colour.layer(i).1;
        }
        let result = at;
        colour_out.push(result + 1);
        Self { grid, density, colour, density_out, colour_out, colour_in, result, stride: result + 4 }
    }

    /// Number of MLP weights.
    pub fn mlp_params(&self) -> usize {
        self.colour.end()
    }

    /// Floats saved per sample for the backward pass.
    pub fn saved_per_sample(&self) -> usize {
        self.stride
    }

    /// Floats per sample of the density's activations (the encoding and the density MLP's
    /// layers): the start of a saved row, which [`Self::density_saving`] gives and
    /// [`Self::forward_from_density`] starts from.
    pub fn density_width(&self) -> usize {
        self.colour_in + self.density.output()
    }

    /// Evaluates `σ, r, g, b` (`S×4`) at `positions` (`S×3`, in `[0,1]`) seen along unit
    /// `directions` (`S×3`), each sample's pixel footprint of standard deviation
    /// `footprints` (`S`, box units; see [`HashGridLayout::weigh_by_footprint`]). With
    /// `saved` (`S×`[`Self::saved_per_sample`]) it keeps the activations that
    /// [`Self::backward`] needs.
    #[allow(clippy::too_many_arguments)]
    pub fn forward(
        &self,
        positions: &[f32],
        footprints: &[f32],
        directions: &[f32],
        table: &[f32],
        mlp: &[f32],
        out: &mut [f32],
        saved: Option<&mut [f32]>,
    ) {
        assert_eq!(positions.len(), directions.len(), "one direction per position");
        assert_eq!(positions.len(), 3 * footprints.len(), "one footprint per position");
        self.forward_with(FieldInput::Positions { positions, footprints, table }, directions, mlp, out, saved);
    }

    /// As [`Self::forward`], from the density's activations at the positions
    /// (`S×`[`Self::density_width`], as [`Self::density_saving`] gave them with the same
    /// weights): the encoding and the density MLP are not evaluated again.
    pub fn forward_from_density(
        &self,
        density: &[f32],
        directions: &[f32],
        mlp: &[f32],
        out: &mut [f32],
        saved: Option<&mut [f32]>,
    ) {
        assert_eq!(density.len() / self.density_width(), directions.len() / 3, "one direction per sample");
        self.forward_with(FieldInput::Density(density), directions, mlp, out, saved);
    }

    fn forward_with(
        &self,
        input: FieldInput<'_>,
        directions: &[f32],
        mlp: &[f32],
        out: &mut [f32],
        saved: Option<&mut [f32]>,
    ) {
        let s = directions.len() / 3;
        assert_eq!(out.len(), s * 4, "output is S×4");
        assert_eq!(mlp.len(), self.mlp_params(), "MLP weights have the wrong size");
        let stride = self.stride;
        let width = self.density_width();
        let directions_width = self.colour.input() - self.density.output();
        let run = |c: usize, out: &mut [f32], act: &mut [f32]| {
            wide(
                #[inline(always)]
                || {
                    let n = out.len() / 4;
                    let rows = c * CHUNK..c * CHUNK + n;
                    match input {
                        FieldInput::Positions { positions, footprints, table } => {
                            let pos = &positions[3 * rows.start..3 * rows.end];
                            self.grid.encode_chunk(pos, table, act, stride);
                            self.grid.weigh_by_footprint(act, stride, &footprints[rows.clone()]);
                            self.mlp_forward(&self.density, 0, &self.density_out, mlp, act, n, stride);
                        }
                        FieldInput::Density(density) => {
                            for (row, d) in
                                act.chunks_mut(stride).zip(density[width * rows.start..width * rows.end].chunks(width))
                            {
                                row[..width].copy_from_slice(d);
                            }
                        }
                    }
                    let dir = &directions[3 * rows.start..3 * rows.end];
                    for i in 0..n {
                        let row = &mut act[i * stride..(i + 1) * stride];
                        let sh = &mut row[width..][..directions_width];
                        sh_encode([dir[3 * i], dir[3 * i + 1], dir[3 * i + 2]], sh);
                    }
                    self.mlp_forward(&self.colour, self.colour_in, &self.colour_out, mlp, act, n, stride);
                    for i in 0..n {
                        let row = &mut act[i * stride..(i + 1) * stride];
                        row[self.result] = row[self.colour_in].min(MAX_LOG_DENSITY).exp();
                        for c in 1..4 {
                            row[self.result + c] = sigmoid(row[self.result + c]);
                        }
                        out[4 * i..4 * i + 4].copy_from_slice(&row[self.result..self.result + 4]);
                    }
                },
            )
        };
        match saved {
            Some(saved) => {
                assert_eq!(saved.len(), s * stride, "saved activations are S×{stride}");
                saved
                    .par_chunks_mut(CHUNK * stride)
                    .zip(out.par_chunks_mut(CHUNK * 4))
                    .enumerate()
                    .for_each(|(c, (act, out))| run(c, out, act));
            }
            None => out
                .par_chunks_mut(CHUNK * 4)
                .enumerate()
                .for_each_init(|| vec![0.0; CHUNK * stride], |act, (c, out)| run(c, out, act)),
        }
    }

    /// Density `σ` only (`S`), for the occupancy grid: no colour MLP.
    pub fn density(&self, positions: &[f32], footprints: &[f32], table: &[f32], mlp: &[f32], out: &mut [f32]) {
        assert_eq!(out.len(), positions.len() / 3, "one density per position");
        assert_eq!(out.len(), footprints.len(), "one footprint per position");
        let width = self.density_width();
        out.par_chunks_mut(CHUNK).zip(positions.par_chunks(CHUNK * 3).zip(footprints.par_chunks(CHUNK))).for_each_init(
            || vec![0.0; CHUNK * width],
            |act, (out, (pos, foot))| self.density_chunk(pos, foot, table, mlp, out, act),
        );
    }

    /// Density `σ` (`S`) and the activations that gave it (`S×`[`Self::density_width`]), from
    /// which [`Self::forward_from_density`] goes on.
    pub fn density_saving(
        &self,
        positions: &[f32],
        footprints: &[f32],
        table: &[f32],
        mlp: &[f32],
        out: &mut [f32],
        saved: &mut [f32],
    ) {
        let width = self.density_width();
        assert_eq!(out.len(), positions.len() / 3, "one density per position");
        assert_eq!(out.len(), footprints.len(), "one footprint per position");
        assert_eq!(saved.len(), out.len() * width, "saved activations are S×{width}");
        out.par_chunks_mut(CHUNK)
            .zip(
                positions
                    .par_chunks(CHUNK * 3)
                    .zip(footprints.par_chunks(CHUNK))
                    .zip(saved.par_chunks_mut(CHUNK * width)),
            )
            .for_each(|(out, ((pos, foot), act))| self.density_chunk(pos, foot, table, mlp, out, act));
    }

    /// Encoding and density MLP of one chunk, in rows of [`Self::density_width`].
    fn density_chunk(&self, pos: &[f32], foot: &[f32], table: &[f32], mlp: &[f32], out: &mut [f32], act: &mut [f32]) {
        wide(
            #[inline(always)]
            || {
                let (n, width) = (out.len(), self.density_width());
                self.grid.encode_chunk(pos, table, act, width);
                self.grid.weigh_by_footprint(act, width, foot);
                self.mlp_forward(&self.density, 0, &self.density_out, mlp, act, n, width);
                for (i, o) in out.iter_mut().enumerate() {
                    *o = act[i * width + self.colour_in].min(MAX_LOG_DENSITY).exp();
                }
            },
        )
    }

    /// Runs one MLP on `n` rows of `stride` floats: input at column `input`, layer `i`'s
    /// output at `outputs[i]`; ReLU on hidden layers, the last layer linear.
    #[inline(always)]
    #[allow(unsafe_code, clippy::too_many_arguments)] // interleaved columns of one buffer: see the SAFETY note
    fn mlp_forward(
        &self,
        shape: &MlpShape,
        input: usize,
        outputs: &[usize],
        w: &[f32],
        act: &mut [f32],
        n: usize,
        stride: usize,
    ) {
        let mut from = input;
        for (l, &to) in outputs.iter().enumerate() {
            let (k, m, off) = shape.layer(l);
            assert!(n == 0 || (n - 1) * stride + (from + k).max(to + m) <= act.len(), "rows out of bounds");
            assert!(from + k <= to || to + m <= from, "layer input and output overlap");
            let weights = &w[off..off + k * m];
            let base = act.as_mut_ptr();
            // SAFETY: in bounds by the asserts; within each row the input columns
            // [from, from+k) and output columns [to, to+m) are disjoint, so gemm never writes
            // an element it reads. Both pointers derive from the one `&mut act`.
            unsafe {
                matmul_raw(n, m, k, (base.add(from), stride, 1), (weights.as_ptr(), m, 1), base.add(to), stride, false);
            }
            let tail = &mut act[to..];
            if l + 1 < outputs.len() {
                for i in 0..n {
                    for v in &mut tail[i * stride..i * stride + m] {
                        *v = v.max(0.0);
                    }
                }
            }
            from = to;
        }
    }

    /// Accumulates `∂loss/∂table` and `∂loss/∂mlp` (zeroed by the caller) from
    /// `∂loss/∂out` (`S×4`), using the activations saved by [`Self::forward`].
    #[allow(clippy::too_many_arguments)]
    pub fn backward(
        &self,
        positions: &[f32],
        footprints: &[f32],
        mlp: &[f32],
        saved: &[f32],
        grad_out: &[f32],
        grad_table: &mut [f32],
        grad_mlp: &mut [f32],
    ) {
        let s = positions.len() / 3;
        let stride = self.stride;
        assert_eq!(saved.len(), s * stride, "saved activations do not match the positions");
        assert_eq!(footprints.len(), s, "one footprint per position");
        assert_eq!(grad_out.len(), s * 4, "output gradient is S×4");
        assert_eq!(grad_mlp.len(), self.mlp_params(), "MLP gradient has the wrong size");
        // Samples past a ray's early termination (often half the batch) have an all-zero
        // gradient: compact them away before the MLP backward and the table scatter.
        let active: Vec<usize> = (0..s).filter(|&i| grad_out[4 * i..4 * i + 4].iter().any(|&g| g != 0.0)).collect();
        tracing::trace!(samples = s, active = active.len(), "field backward");
        let compacted;
        let (positions, footprints, saved, grad_out) = if active.len() == s {
            (positions, footprints, saved, grad_out)
        } else {
            compacted = (
                gather_rows(positions, 3, &active),
                gather_rows(footprints, 1, &active),
                gather_rows(saved, stride, &active),
                gather_rows(grad_out, 4, &active),
            );
            (&compacted.0[..], &compacted.1[..], &compacted.2[..], &compacted.3[..])
        };
        let s = active.len();
        let enc = self.grid.output_dim();
        let mut grad_enc = vec![0.0f32; s * enc];
        let widest = self.widest();
        // Weight gradients are summed per fixed group of chunks, then the groups in order: the
        // same float additions whatever the thread count, so training is reproducible.
        let group = CHUNK * GROUP_CHUNKS;
        let partials: Vec<Vec<f32>> = grad_enc
            .par_chunks_mut(group * enc)
            .zip(saved.par_chunks(group * stride).zip(grad_out.par_chunks(group * 4)))
            .map(|(genc, (act, gout))| {
                let mut gw = vec![0.0f32; self.mlp_params()];
                let (mut ga, mut gb) = (vec![0.0f32; CHUNK * widest], vec![0.0f32; CHUNK * widest]);
                for ((genc, act), gout) in
                    genc.chunks_mut(CHUNK * enc).zip(act.chunks(CHUNK * stride)).zip(gout.chunks(CHUNK * 4))
                {
                    wide(
                        #[inline(always)]
                        || self.backward_chunk(mlp, act, gout, genc, &mut gw, &mut ga, &mut gb),
                    );
                }
                gw
            })
            .collect();
        for gw in partials {
            grad_mlp.iter_mut().zip(&gw).for_each(|(d, g)| *d += g);
        }
        // The features entered the MLP weighted: so does their gradient reach the table.
        grad_enc
            .par_chunks_mut(CHUNK * enc)
            .zip(footprints.par_chunks(CHUNK))
            .for_each(|(g, foot)| self.grid.weigh_by_footprint(g, enc, foot));
        self.grid.backward(positions, &grad_enc, grad_table);
    }

    fn widest(&self) -> usize {
        let mut w = self.grid.output_dim().max(self.colour.input()).max(4);
        for shape in [&self.density, &self.colour] {
            for l in 0..shape.layers() {
                w = w.max(shape.layer(l).1);
            }
        }
        w
    }

    /// One chunk of the backward pass: from `∂/∂(σ, rgb)` down to `∂/∂encoding`, adding the
    /// weight gradients to `gw`. `ga`/`gb` are scratch blocks of `CHUNK × widest` floats.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn backward_chunk(
        &self,
        w: &[f32],
        act: &[f32],
        gout: &[f32],
        genc: &mut [f32],
        gw: &mut [f32],
        ga: &mut [f32],
        gb: &mut [f32],
    ) {
        let stride = self.stride;
        let n = gout.len() / 4;
        // Colour: ∂/∂logit = ∂/∂rgb · s(1−s); ga holds the gradient of the current layer's output.
        for i in 0..n {
            for c in 0..3 {
                let s = act[i * stride + self.result + 1 + c];
                ga[i * 3 + c] = gout[i * 4 + 1 + c] * s * (1.0 - s);
            }
        }
        let gin = self.mlp_backward(&self.colour, self.colour_in, &self.colour_out, w, act, n, gw, ga, gb);
        // ∂/∂(geometry features) is the first part of ∂/∂(colour input); add σ's own path.
        let g = self.density.output();
        let cin = self.colour.input();
        let (grad_colour_in, other) = if gin { (&mut *gb, &mut *ga) } else { (&mut *ga, &mut *gb) };
        for i in 0..n {
            let raw = act[i * stride + self.colour_in];
            let dexp = raw.clamp(-MAX_LOG_DENSITY, MAX_LOG_DENSITY).exp();
            other[i * g..(i + 1) * g].copy_from_slice(&grad_colour_in[i * cin..i * cin + g]);
            other[i * g] += gout[i * 4] * dexp;
        }
        let gin = self.mlp_backward(&self.density, 0, &self.density_out, w, act, n, gw, other, grad_colour_in);
        let grad_enc = if gin { &*grad_colour_in } else { &*other };
        let e = self.grid.output_dim();
        genc[..n * e].copy_from_slice(&grad_enc[..n * e]);
    }

    /// Backward through one MLP for `n` rows, adding the weight gradients to `gw`. `g` holds
    /// `∂/∂output` (rows packed at the output width); `spare` is scratch. Returns whether
    /// `∂/∂input` (packed at the input width) ended in `spare` (`true`) or in `g` (`false`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn mlp_backward(
        &self,
        shape: &MlpShape,
        input: usize,
        outputs: &[usize],
        w: &[f32],
        act: &[f32],
        n: usize,
        gw: &mut [f32],
        g: &mut [f32],
        spare: &mut [f32],
    ) -> bool {
        let stride = self.stride;
        let (mut cur, mut next) = (g, spare);
        let mut swapped = false;
        for l in (0..shape.layers()).rev() {
            let (k, m, off) = shape.layer(l);
            let from = if l == 0 { input } else { outputs[l - 1] };
            // ∂W += Xᵀ·∂Y
            let x_t = View::transposed(&act[from..], stride);
            matmul(k, m, n, x_t, View::rows(cur, m), &mut gw[off..off + k * m], m, true);
            // ∂X = ∂Y·Wᵀ, then back through the ReLU that produced X (hidden layers only).
            let w_t = View::transposed(&w[off..off + k * m], m);
            matmul(n, k, m, View::rows(cur, m), w_t, next, k, false);
            if l > 0 {
                for i in 0..n {
                    let x = &act[i * stride + from..i * stride + from + k];
                    for (d, &v) in next[i * k..(i + 1) * k].iter_mut().zip(x) {
                        if v <= 0.0 {
                            *d = 0.0;
                        }
                    }
                }
            }
            std::mem::swap(&mut cur, &mut next);
            swapped = !swapped;
        }
        swapped
    }
}

/// Where the field's forward starts: positions (and the table), or the density's activations.
#[derive(Clone, Copy)]
enum FieldInput<'a> {
    Positions { positions: &'a [f32], footprints: &'a [f32], table: &'a [f32] },
    Density(&'a [f32]),
}

/// The rows `indices` of a row-major matrix of `width` columns.
fn gather_rows(data: &[f32], width: usize, indices: &[usize]) -> Vec<f32> {
    let mut out = vec![0.0; indices.len() * width];
    out.par_chunks_mut(width * 1024).zip(indices.par_chunks(1024)).for_each(|(out, idx)| {
        for (o, &i) in out.chunks_exact_mut(width).zip(idx) {
            o.copy_from_slice(&data[i * width..(i + 1) * width]);
        }
    });
    out
}

#[inline]
fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

#[cfg(test)]
pub(crate) mod tests;
