//! Eight `f32` lanes as a value type, each operation a loop over the lanes: the packet
//! tracer's vertex, light-sample and continuation arithmetic is written with these, so that
//! every operation is one short loop that the compiler turns into one vector instruction (8
//! lanes under AVX2, two 4-lane halves otherwise), where a whole bounce written as one lane
//! loop was too much for the loop vectoriser and ran lane by lane. Each lane computes exactly
//! what the scalar `f32` and glam code computes (same operations, same order), so the packet
//! paths stay bit-identical to the single-path tracer's. Written by hand: the SIMD crates pick
//! their instruction set at compile time and give `min`/`max` other NaN rules than `f32`'s.

// Lane loops index several arrays with one lane number.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};

/// Lanes per value.
pub(super) const N: usize = 8;

/// Eight floats.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub(super) struct F8(pub(super) [f32; N]);

/// Eight lane conditions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct M8(pub(super) [bool; N]);

/// Eight 3-vectors, one `F8` per coordinate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct V8 {
    pub(super) x: F8,
    pub(super) y: F8,
    pub(super) z: F8,
}

macro_rules! lanewise {
    ($l:ident => $e:expr) => {{
        let mut out = [Default::default(); N];
        for $l in 0..N {
            out[$l] = $e;
        }
        out
    }};
}

macro_rules! binary {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, rhs: F8) -> F8 {
                F8(lanewise!(l => self.0[l] $op rhs.0[l]))
            }
        }
        impl $trait<f32> for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, rhs: f32) -> F8 {
                F8(lanewise!(l => self.0[l] $op rhs))
            }
        }
        impl $trait<F8> for f32 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, rhs: F8) -> F8 {
                F8(lanewise!(l => self $op rhs.0[l]))
            }
        }
    };
}

binary!(Add, add, +);
binary!(Sub, sub, -);
binary!(Mul, mul, *);
binary!(Div, div, /);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        F8(lanewise!(l => -self.0[l]))
    }
}

macro_rules! compare {
    ($method:ident, $op:tt) => {
        #[inline(always)]
        pub(super) fn $method(self, rhs: impl Into<F8>) -> M8 {
            let rhs = rhs.into();
            M8(lanewise!(l => self.0[l] $op rhs.0[l]))
        }
    };
}

impl From<f32> for F8 {
    #[inline(always)]
    fn from(v: f32) -> F8 {
        F8([v; N])
    }
}

impl F8 {
    compare!(gt, >);
    compare!(ge, >=);
    compare!(ne, !=);
    compare!(eq, ==);

    /// `f32::sqrt` per lane.
    #[inline(always)]
    pub(super) fn sqrt(self) -> F8 {
        F8(lanewise!(l => self.0[l].sqrt()))
    }

    /// `f32::abs` per lane.
    #[inline(always)]
    pub(super) fn abs(self) -> F8 {
        F8(lanewise!(l => self.0[l].abs()))
    }

    /// `f32::max` per lane (a NaN lane takes the other operand).
    #[inline(always)]
    pub(super) fn max(self, rhs: impl Into<F8>) -> F8 {
        let rhs = rhs.into();
        F8(lanewise!(l => self.0[l].max(rhs.0[l])))
    }

    /// `f32::clamp` per lane (`lo <= hi`; NaN stays NaN).
    #[inline(always)]
    pub(super) fn clamp(self, lo: f32, hi: f32) -> F8 {
        F8(lanewise!(l => self.0[l].clamp(lo, hi)))
    }

    /// Lanes whose value is finite.
    #[inline(always)]
    pub(super) fn is_finite(self) -> M8 {
        M8(lanewise!(l => self.0[l].is_finite()))
    }
}

impl BitAnd for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitand(self, rhs: M8) -> M8 {
        M8(lanewise!(l => self.0[l] & rhs.0[l]))
    }
}

impl BitOr for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitor(self, rhs: M8) -> M8 {
        M8(lanewise!(l => self.0[l] | rhs.0[l]))
    }
}

impl M8 {
    /// `a` where set, `b` elsewhere.
    #[inline(always)]
    pub(super) fn select(self, a: F8, b: F8) -> F8 {
        F8(lanewise!(l => if self.0[l] { a.0[l] } else { b.0[l] }))
    }

    /// [`M8::select`] per coordinate.
    #[inline(always)]
    pub(super) fn select3(self, a: V8, b: V8) -> V8 {
        V8 { x: self.select(a.x, b.x), y: self.select(a.y, b.y), z: self.select(a.z, b.z) }
    }
}

impl V8 {
    /// `Vec3::dot`: `(x·x' + y·y') + z·z'`.
    #[inline(always)]
    pub(super) fn dot(self, rhs: V8) -> F8 {
        self.x * rhs.x + self.y * rhs.y + self.z * rhs.z
    }

    /// `Vec3::length_squared`.
    #[inline(always)]
    pub(super) fn length_squared(self) -> F8 {
        self.dot(self)
    }

    /// `Vec3::length`.
    #[inline(always)]
    pub(super) fn length(self) -> F8 {
        self.dot(self).sqrt()
    }

    /// `Vec3::abs`.
    #[inline(always)]
    pub(super) fn abs(self) -> V8 {
        V8 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// `Vec3::max_element`: `max(max(x, y), z)` with glam's `a > b ? a : b`.
    #[inline(always)]
    pub(super) fn max_element(self) -> F8 {
        let xy = self.x.gt(self.y).select(self.x, self.y);
        xy.gt(self.z).select(xy, self.z)
    }

    /// `Vec3::normalize` (no check: a zero vector gives NaN lanes, as there).
    #[inline(always)]
    pub(super) fn normalize(self) -> V8 {
        self * (1.0 / self.length())
    }
}

macro_rules! vector {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for V8 {
            type Output = V8;
            #[inline(always)]
            fn $method(self, rhs: V8) -> V8 {
                V8 { x: self.x $op rhs.x, y: self.y $op rhs.y, z: self.z $op rhs.z }
            }
        }
        impl $trait<F8> for V8 {
            type Output = V8;
            #[inline(always)]
            fn $method(self, rhs: F8) -> V8 {
                V8 { x: self.x $op rhs, y: self.y $op rhs, z: self.z $op rhs }
            }
        }
    };
}

vector!(Add, add, +);
vector!(Sub, sub, -);
vector!(Mul, mul, *);
vector!(Div, div, /);

impl Mul<V8> for F8 {
    type Output = V8;
    #[inline(always)]
    fn mul(self, rhs: V8) -> V8 {
        V8 { x: self * rhs.x, y: self * rhs.y, z: self * rhs.z }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn lanes(f: impl Fn(usize) -> Vec3) -> V8 {
        let v: [Vec3; N] = std::array::from_fn(f);
        V8 { x: F8(v.map(|v| v.x)), y: F8(v.map(|v| v.y)), z: F8(v.map(|v| v.z)) }
    }

    fn lane(v: V8, l: usize) -> Vec3 {
        Vec3::new(v.x.0[l], v.y.0[l], v.z.0[l])
    }

    #[test]
    fn lane_operations_are_the_scalar_ones_bit_for_bit() {
        let a = lanes(|l| Vec3::new(0.3 * l as f32 - 1.1, 1.7 / (l as f32 + 0.5), (l as f32).sin()));
        let b = lanes(|l| Vec3::new((l as f32 * 0.7).cos(), -0.2 * l as f32, 0.9 - 0.01 * l as f32));
        // Ties and NaN, where `a > b ? a : b` and `f32::max` differ.
        let odd = lanes(|l| [Vec3::new(0.0, -0.0, 1.0), Vec3::new(f32::NAN, 2.0, 1.0), Vec3::splat(-3.0)][l % 3]);
        for l in 0..N {
            let (x, y) = (lane(a, l), lane(b, l));
            assert_eq!(a.dot(b).0[l], x.dot(y));
            assert_eq!(lane(a.normalize(), l), x.normalize());
            assert_eq!(a.abs().max_element().0[l], x.abs().max_element());
            assert_eq!(odd.max_element().0[l].to_bits(), lane(odd, l).max_element().to_bits());
            assert_eq!(lane(a * b.x - b / a.y + a.z * b, l), x * y.x - y / x.y + x.z * y);
            assert_eq!((a.x / b.y).max(0.5).clamp(0.0, 0.9).0[l], (x.x / y.y).max(0.5).clamp(0.0, 0.9));
            assert_eq!(a.length_squared().sqrt().0[l], x.length());
        }
        let m = a.x.gt(b.x) | a.y.ge(0.0) & b.z.ne(0.9);
        for l in 0..N {
            let expect = a.x.0[l] > b.x.0[l] || (a.y.0[l] >= 0.0 && b.z.0[l] != 0.9);
            assert_eq!(m.0[l], expect);
            assert_eq!(m.select(a.x, b.x).0[l], if expect { a.x.0[l] } else { b.x.0[l] });
        }
        assert_eq!(
            (1.0 / F8([0.0, 1.0, -0.0, 2.0, 0.5, 3.0, f32::NAN, 4.0])).is_finite().0,
            [false, true, false, true, true, true, false, true]
        );
    }
}
