//! Kelemen et al.'s primary-sample-space sampler (pbrt-v3's `MLTSampler`, written fresh): the
//! uniforms an estimator draws are the coordinates of a point that a Markov chain mutates.
//! A large step replaces every coordinate with a fresh uniform; a small step perturbs each by a
//! normal of standard deviation σ, wrapped to [0, 1). Coordinates are mutated lazily, when the
//! estimator first asks for them in an iteration: one not read for k small steps gets one
//! normal of deviation σ√k (k independent perturbations sum to that), and one not read since
//! the last accepted large step is first drawn afresh.

use std::f32::consts::TAU;

use crate::sampling::{Rng, UniformSource};

#[derive(Clone, Copy, Default)]
struct Coordinate {
    value: f32,
    /// The iteration that last changed it.
    modified: u64,
    backup: f32,
    backup_modified: u64,
}

/// A point of primary sample space and its mutations.
pub(crate) struct PrimarySampleSpace {
    rng: Rng,
    sigma: f32,
    large_step_probability: f32,
    coordinates: Vec<Coordinate>,
    iteration: u64,
    large_step: bool,
    last_large_step: u64,
    next: usize,
}

impl PrimarySampleSpace {
    /// A point whose first evaluation reads fresh uniforms from stream `stream` of `seed`
    /// (so a bootstrap sample is reproduced by its stream).
    pub(crate) fn new(seed: u64, stream: u64, sigma: f32, large_step_probability: f32) -> Self {
        Self {
            rng: Rng::new(seed, stream),
            sigma,
            large_step_probability,
            coordinates: Vec::new(),
            iteration: 0,
            large_step: true,
            last_large_step: 0,
            next: 0,
        }
    }

    /// Starts a proposal: a large step with the large-step probability, else a small one.
    pub(crate) fn start_iteration(&mut self) {
        self.iteration += 1;
        self.large_step = self.rng.uniform() < self.large_step_probability;
        self.next = 0;
    }

    /// Keeps the proposal.
    pub(crate) fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
        }
    }

    /// Returns to the point before the proposal.
    pub(crate) fn reject(&mut self) {
        for c in &mut self.coordinates {
            if c.modified == self.iteration {
                c.value = c.backup;
                c.modified = c.backup_modified;
            }
        }
        self.iteration -= 1;
    }

    /// Reads the coordinates from the first again, within the same iteration.
    #[cfg(test)]
    fn restart_reading(&mut self) {
        self.next = 0;
    }

    fn mutate(&mut self, i: usize) {
        if i >= self.coordinates.len() {
            self.coordinates.resize(i + 1, Coordinate::default());
        }
        let c = &mut self.coordinates[i];
        if c.modified < self.last_large_step {
            c.value = self.rng.uniform();
            c.modified = self.last_large_step;
        }
        c.backup = c.value;
        c.backup_modified = c.modified;
        if self.large_step {
            c.value = self.rng.uniform();
        } else {
            let steps = (self.iteration - c.modified) as f32;
            // Box–Muller: one standard normal from two uniforms.
            let (u1, u2) = (1.0 - self.rng.uniform(), self.rng.uniform());
            let normal = (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos();
            c.value += normal * self.sigma * steps.sqrt();
            c.value -= c.value.floor();
            // Rounding can leave exactly 1 after wrapping a tiny negative value.
            c.value = c.value.min(1.0 - f32::EPSILON / 2.0);
        }
        c.modified = self.iteration;
    }
}

impl UniformSource for PrimarySampleSpace {
    fn uniform(&mut self) -> f32 {
        let i = self.next;
        self.next += 1;
        if self.coordinates.get(i).is_none_or(|c| c.modified != self.iteration) {
            self.mutate(i);
        }
        self.coordinates[i].value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejected_proposals_restore_the_point_and_small_steps_stay_close() {
        let mut s = PrimarySampleSpace::new(1, 2, 0.01, 0.0);
        let first: Vec<f32> = (0..6).map(|_| s.uniform()).collect();
        s.restart_reading();
        let again: Vec<f32> = (0..6).map(|_| s.uniform()).collect();
        assert_eq!(first, again, "reading again within an iteration gives the same point");
        s.start_iteration();
        let moved: Vec<f32> = (0..6).map(|_| s.uniform()).collect();
        for (a, b) in first.iter().zip(&moved) {
            let d = (a - b).abs().min(1.0 - (a - b).abs());
            assert!(d > 0.0 && d < 0.08, "small step moved {a} to {b}");
        }
        s.reject();
        s.start_iteration();
        s.reject();
        s.restart_reading();
        // Reading after a rejection mutates from the restored point, not from the proposal.
        s.start_iteration();
        let from_restored: Vec<f32> = (0..6).map(|_| s.uniform()).collect();
        for (a, b) in first.iter().zip(&from_restored) {
            let d = (a - b).abs().min(1.0 - (a - b).abs());
            assert!(d < 0.08, "{a} → {b}");
        }
    }

    /// Small steps leave the uniform distribution invariant: a long chain of always-accepted
    /// small steps covers [0, 1) evenly.
    #[test]
    fn small_steps_keep_coordinates_uniform() {
        let mut s = PrimarySampleSpace::new(3, 0, 0.05, 0.0);
        let mut bins = [0u32; 10];
        for _ in 0..200_000 {
            s.start_iteration();
            let x = s.uniform();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
            s.accept();
        }
        for b in bins {
            assert!((b as f64 / 20_000.0 - 1.0).abs() < 0.1, "{bins:?}");
        }
    }
}
