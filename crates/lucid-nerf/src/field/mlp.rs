//! Dense layers without biases (as tiny-cuda-nn's fully fused MLPs) over row-major blocks of
//! samples, on `gemm`'s SIMD kernels. Weights of all layers live in one flat slice; the shape
//! says where each layer's `in×out` matrix starts.
//!
//! `gemm` is an unsafe raw-pointer API; this module is the one place that calls it, each call
//! guarded by bounds checks.
#![allow(unsafe_code)]

/// Layer widths of one MLP, input first: `[in, hidden…, out]`.
#[derive(Clone, Debug, PartialEq)]
pub struct MlpShape {
    dims: Vec<usize>,
    offsets: Vec<usize>,
}

impl MlpShape {
    /// An MLP with the given widths, whose weights start at `offset` in the flat parameters.
    pub fn new(dims: Vec<usize>, offset: usize) -> Self {
        assert!(dims.len() >= 2, "an MLP has an input and an output");
        let mut offsets = Vec::with_capacity(dims.len() - 1);
        let mut at = offset;
        for w in dims.windows(2) {
            offsets.push(at);
            at += w[0] * w[1];
        }
        Self { dims, offsets }
    }

    /// Number of layers (matrices).
    pub fn layers(&self) -> usize {
        self.offsets.len()
    }

    /// `(inputs, outputs, offset)` of layer `i`.
    pub fn layer(&self, i: usize) -> (usize, usize, usize) {
        (self.dims[i], self.dims[i + 1], self.offsets[i])
    }

    /// Width of layer `i`'s input.
    pub fn input(&self) -> usize {
        self.dims[0]
    }

    /// Width of the output.
    pub fn output(&self) -> usize {
        *self.dims.last().expect("non-empty")
    }

    /// First flat index after this MLP's weights.
    pub fn end(&self) -> usize {
        let (i, o, off) = self.layer(self.layers() - 1);
        off + i * o
    }
}

/// A row-major matrix view: element `(r, c)` at `data[r·rs + c·cs]`.
#[derive(Clone, Copy)]
pub struct View<'a> {
    /// The storage.
    pub data: &'a [f32],
    /// Row stride.
    pub rs: usize,
    /// Column stride.
    pub cs: usize,
}

impl<'a> View<'a> {
    /// Rows of length `cols` spaced `stride` apart.
    pub fn rows(data: &'a [f32], stride: usize) -> Self {
        Self { data, rs: stride, cs: 1 }
    }

    /// The transpose of a row-major matrix whose rows are spaced `stride` apart.
    pub fn transposed(data: &'a [f32], stride: usize) -> Self {
        Self { data, rs: 1, cs: stride }
    }

    fn last_index(&self, rows: usize, cols: usize) -> usize {
        (rows - 1) * self.rs + (cols - 1) * self.cs
    }
}

/// `dst[m×n] (+)= a[m×k] · b[k×n]`, with `dst` rows spaced `dst_stride` apart.
#[allow(clippy::too_many_arguments)]
pub fn matmul(m: usize, n: usize, k: usize, a: View, b: View, dst: &mut [f32], dst_stride: usize, accumulate: bool) {
    if m == 0 || n == 0 {
        return;
    }
    if k == 0 {
        if !accumulate {
            for r in 0..m {
                dst[r * dst_stride..r * dst_stride + n].fill(0.0);
            }
        }
        return;
    }
    assert!(a.last_index(m, k) < a.data.len(), "lhs out of bounds");
    assert!(b.last_index(k, n) < b.data.len(), "rhs out of bounds");
    assert!((m - 1) * dst_stride + n <= dst.len(), "destination out of bounds");
    // SAFETY: the asserts above keep every element gemm touches inside the three slices, and
    // `dst` is borrowed mutably, so it cannot alias `a` or `b`.
    unsafe {
        let (a, b) = ((a.data.as_ptr(), a.rs, a.cs), (b.data.as_ptr(), b.rs, b.cs));
        matmul_raw(m, n, k, a, b, dst.as_mut_ptr(), dst_stride, accumulate);
    }
}

/// `dst[m×n] (+)= a[m×k] · b[k×n]` on raw `(pointer, row stride, column stride)` operands,
/// for products whose input and output columns interleave in one buffer (the rows of saved
/// activations), where slices would alias.
///
/// # Safety
/// Every element of the three matrices must be in bounds, and no element of `dst` may be an
/// element of `a` or `b`.
#[allow(clippy::too_many_arguments)]
pub unsafe fn matmul_raw(
    m: usize,
    n: usize,
    k: usize,
    a: (*const f32, usize, usize),
    b: (*const f32, usize, usize),
    dst: *mut f32,
    dst_stride: usize,
    accumulate: bool,
) {
    // SAFETY: forwarded to the caller.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst,
            1,
            dst_stride as isize,
            accumulate,
            a.0,
            a.2 as isize,
            a.1 as isize,
            b.0,
            b.2 as isize,
            b.1 as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matmul_matches_naive_products_with_strides_and_transposes() {
        let (m, n, k) = (5, 3, 4);
        let a: Vec<f32> = (0..m * k).map(|i| (i as f32 * 0.37).sin()).collect();
        let b: Vec<f32> = (0..k * n).map(|i| (i as f32 * 0.91).cos()).collect();
        let naive = |r: usize, c: usize| (0..k).map(|j| a[r * k + j] * b[j * n + c]).sum::<f32>();
        // Plain product into a strided destination, then accumulate a second time.
        let stride = n + 2;
        let mut dst = vec![7.0; m * stride];
        matmul(m, n, k, View::rows(&a, k), View::rows(&b, n), &mut dst, stride, false);
        matmul(m, n, k, View::rows(&a, k), View::rows(&b, n), &mut dst, stride, true);
        for r in 0..m {
            for c in 0..n {
                assert!((dst[r * stride + c] - 2.0 * naive(r, c)).abs() < 1e-5);
            }
            assert_eq!(dst[r * stride + n], 7.0, "padding untouched");
        }
        // (aᵀ)ᵀ · (bᵀ)ᵀ through transposed views of the transposed storages.
        let at: Vec<f32> = (0..k * m).map(|i| a[(i % m) * k + i / m]).collect();
        let bt: Vec<f32> = (0..n * k).map(|i| b[(i % k) * n + i / k]).collect();
        let mut dst2 = vec![0.0; m * n];
        matmul(m, n, k, View::transposed(&at, m), View::transposed(&bt, k), &mut dst2, n, false);
        for r in 0..m {
            for c in 0..n {
                assert!((dst2[r * n + c] - naive(r, c)).abs() < 1e-5);
            }
        }
    }
}
