//! Kubelka–Munk layers: the diffuse reflectance and transmittance of a scattering, absorbing
//! film (paint, a pigmented coat) and of a stack of films over an opaque base.
//!
//! A layer of thickness `d` with absorption `K` and scattering `S` per unit length reflects
//! `R = sinh(bSd) / (a sinh(bSd) + b cosh(bSd))` and transmits `T = b / (a sinh(bSd) + b cosh(bSd))`,
//! with `a = 1 + K/S` and `b = √(a² − 1)` (Kubelka 1948); without scattering it only absorbs,
//! `T = e^{−Kd}`. Two layers compose by summing the light's bounces between them — the
//! geometric series of the reference notes — `R₁₂ = R₁ + T₁ R₂ T₁ / (1 − R₁ R₂)` and
//! `T₁₂ = T₁ T₂ / (1 − R₁ R₂)`. Kubelka–Munk layers scatter the same from either side, so a
//! stack composes from the base up. The material they make is Lambertian with the stack's
//! reflectance: the theory describes diffuse light only.

use glam::Vec3;

/// One layer's diffuse reflectance and transmittance, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KmLayer {
    /// Reflectance `R`.
    pub reflectance: Vec3,
    /// Transmittance `T` (`R + T ≤ 1`).
    pub transmittance: Vec3,
}

impl KmLayer {
    /// A film of `thickness` with absorption and scattering coefficients per unit length.
    pub fn from_coefficients(absorption: Vec3, scattering: Vec3, thickness: f32) -> Self {
        let mut r = [0.0; 3];
        let mut t = [0.0; 3];
        for c in 0..3 {
            (r[c], t[c]) = km_channel(absorption[c], scattering[c], thickness);
        }
        Self { reflectance: Vec3::from(r), transmittance: Vec3::from(t) }
    }

    /// This layer over `below`: the light bouncing between them summed in closed form.
    pub fn over(&self, below: &KmLayer) -> KmLayer {
        let (r1, t1, r2, t2) = (self.reflectance, self.transmittance, below.reflectance, below.transmittance);
        let bounce = Vec3::ONE / (Vec3::ONE - r1 * r2);
        KmLayer { reflectance: r1 + t1 * r2 * t1 * bounce, transmittance: t1 * t2 * bounce }
    }

    /// This layer over an opaque base of reflectance `base`: the stack's reflectance.
    pub fn over_base(&self, base: Vec3) -> Vec3 {
        self.over(&KmLayer { reflectance: base, transmittance: Vec3::ZERO }).reflectance
    }
}

/// `(R, T)` of one channel; in f64, since `sinh` and `cosh` of thick films grow large.
fn km_channel(k: f32, s: f32, d: f32) -> (f32, f32) {
    let (k, s, d) = (k as f64, s as f64, d as f64);
    if s <= 0.0 {
        return (0.0, (-k * d).exp() as f32);
    }
    let a = 1.0 + k / s;
    let b = (a * a - 1.0).sqrt();
    let x = b * s * d;
    if x > 300.0 {
        // Opaque: R∞ = a − b, nothing through.
        return ((a - b) as f32, 0.0);
    }
    if b < 1e-9 {
        // No absorption: the limit b → 0 of the formulas, R = Sd / (1 + Sd).
        return ((s * d / (1.0 + s * d)) as f32, (1.0 / (1.0 + s * d)) as f32);
    }
    let (sh, ch) = (x.sinh(), x.cosh());
    let denominator = a * sh + b * ch;
    ((sh / denominator) as f32, (b / denominator) as f32)
}

/// The reflectance of `layers` (top first) over an opaque base of reflectance `base`.
pub fn stack_reflectance(layers: &[KmLayer], base: Vec3) -> Vec3 {
    layers.iter().rev().fold(base, |below, layer| layer.over_base(below))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The notes' closed form against the explicit sum of bounce paths: reflect at 1; or cross
    /// 1, bounce k times between 2 and 1, cross 1 back.
    #[test]
    fn composition_equals_the_summed_bounce_series() {
        let top = KmLayer { reflectance: Vec3::new(0.3, 0.5, 0.1), transmittance: Vec3::new(0.6, 0.4, 0.85) };
        let below = KmLayer { reflectance: Vec3::new(0.7, 0.2, 0.45), transmittance: Vec3::new(0.2, 0.5, 0.3) };
        let (mut r, mut t) = (top.reflectance, Vec3::ZERO);
        let mut round_trip = Vec3::ONE;
        for _ in 0..400 {
            r += top.transmittance * below.reflectance * top.transmittance * round_trip;
            t += top.transmittance * below.transmittance * round_trip;
            round_trip *= below.reflectance * top.reflectance;
        }
        let closed = top.over(&below);
        assert!((closed.reflectance - r).abs().max_element() < 1e-6, "{closed:?} vs R {r}");
        assert!((closed.transmittance - t).abs().max_element() < 1e-6, "{closed:?} vs T {t}");
    }

    /// Kubelka–Munk's own consistency: a film is the composition of its two halves, so the
    /// hyperbolic formulas and the bounce series agree.
    #[test]
    fn a_film_is_its_two_halves_stacked() {
        for (k, s, d) in [(0.5, 2.0, 0.3), (0.05, 8.0, 0.7), (3.0, 0.4, 1.5), (0.0, 5.0, 0.2)] {
            let whole = KmLayer::from_coefficients(Vec3::splat(k), Vec3::splat(s), d);
            let half = KmLayer::from_coefficients(Vec3::splat(k), Vec3::splat(s), d / 2.0);
            let stacked = half.over(&half);
            assert!((whole.reflectance - stacked.reflectance).abs().max_element() < 1e-5, "{k} {s} {d}");
            assert!((whole.transmittance - stacked.transmittance).abs().max_element() < 1e-5, "{k} {s} {d}");
        }
    }

    #[test]
    fn films_conserve_energy_and_thick_ones_reach_r_infinity() {
        // No absorption: everything is reflected or transmitted.
        let clear = KmLayer::from_coefficients(Vec3::ZERO, Vec3::splat(3.0), 0.4);
        assert!((clear.reflectance + clear.transmittance - Vec3::ONE).abs().max_element() < 1e-6);
        // Absorbing films lose light, never create it.
        let murky = KmLayer::from_coefficients(Vec3::new(0.2, 1.0, 4.0), Vec3::splat(3.0), 0.4);
        assert!((murky.reflectance + murky.transmittance).cmplt(Vec3::ONE).all());
        // An opaque film reflects R∞ = a − b whatever lies under it.
        let (k, s) = (0.4f32, 2.0f32);
        let a = 1.0 + k / s;
        let r_inf = a - (a * a - 1.0).sqrt();
        let thick = KmLayer::from_coefficients(Vec3::splat(k), Vec3::splat(s), 50.0);
        for base in [Vec3::ZERO, Vec3::ONE] {
            assert!((thick.over_base(base) - Vec3::splat(r_inf)).abs().max_element() < 1e-5);
        }
        // A stack over a white base with clear films stays white.
        let stack = [clear, clear];
        assert!((stack_reflectance(&stack, Vec3::ONE) - Vec3::ONE).abs().max_element() < 1e-5);
    }
}
