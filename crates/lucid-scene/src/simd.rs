//! Wider vectors where the CPU has them, decided at run time.
//!
//! The hot kernels (the splat blend loops, the path tracer's BVH traversal) are written as
//! plain lane loops or glam vector code that the compiler vectorises; built for the baseline
//! x86-64 target they get 4-wide SSE. [`wide`] runs a closure compiled a second time for AVX2
//! (8-wide, three-operand instructions) when the CPU supports it, so one binary is fast on
//! current CPUs and still runs on old ones. Both builds do the same per-lane arithmetic (no
//! fused multiply-adds are enabled), so results are bit-identical either way. Whatever the
//! closure calls must be inlined into it (`#[inline(always)]`) to be compiled for AVX2 too.

/// The environment variable that, set to `baseline`, keeps every kernel on the baseline
/// build: for comparing the two builds bit for bit, and for timing the difference.
pub const SIMD_VARIABLE: &str = "LUCID_SIMD";

/// Whether [`SIMD_VARIABLE`] asks for the baseline build (read once per process).
pub fn baseline_forced() -> bool {
    static FORCED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *FORCED.get_or_init(|| std::env::var(SIMD_VARIABLE).is_ok_and(|v| v.eq_ignore_ascii_case("baseline")))
}

/// Calls `f`, compiled for AVX2 (with the bit-count instructions) if this CPU has it and
/// [`SIMD_VARIABLE`] does not ask for the baseline.
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if !baseline_forced()
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("popcnt")
        && std::arch::is_x86_feature_detected!("bmi1")
    {
        // An AVX2 function may only run on a CPU with AVX2, which the line above checked.
        #[allow(unsafe_code)]
        return unsafe { with_avx2(f) };
    }
    f()
}

#[cfg(target_arch = "x86_64")]
// popcnt and bmi1 (bit counts and scans for lane masks) come with every AVX2 CPU.
#[target_feature(enable = "avx2,popcnt,bmi1")]
fn with_avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

/// Bit `l` set where lane `l`'s sign bit is: one move-mask instruction per 4-lane half. A lane
/// loop that ORs each lane's flag shifted by its lane number compiles instead to a masked AND
/// with the lane weights and a horizontal OR, about a dozen shuffles per mask.
#[inline(always)]
pub fn sign_mask8(v: &[f32; 8]) -> u32 {
    let lo = glam::Vec4::from_slice(&v[..4]).is_negative_bitmask();
    let hi = glam::Vec4::from_slice(&v[4..]).is_negative_bitmask();
    lo | hi << 4
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_mask_sets_the_bits_of_negative_lanes() {
        assert_eq!(sign_mask8(&[-1.0, 2.0, 0.0, -0.5, 3.0, -7.0, 1.0, -1e-30]), 0b1010_1001);
        // +0 is not negative, −0 and negative NaNs are (the sign bit decides).
        assert_eq!(sign_mask8(&[0.0, -0.0, f32::from_bits(0xffc0_0000), 1.0, 0.0, 0.0, 0.0, 0.0]), 0b110);
        assert_eq!(wide(|| sign_mask8(&[-1.0; 8])), 0xff);
    }
}
