//! The `[integrator]` section of a scene file: which light-transport algorithm, its samples,
//! path length and seed, and the parameters of the algorithms that have them.

use serde::Deserialize;

use crate::integrator::PathTracer;
use crate::render::{Integrator, RenderSettings};
use crate::scene_file::SceneFileError;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct IntegratorSection {
    #[serde(rename = "type")]
    kind: String,
    spp: u32,
    max_depth: u32,
    rr_depth: u32,
    hide_emitters: bool,
    seed: u64,
    /// sppm: photons per pass, initial radius, α.
    photons: Option<u32>,
    radius: Option<f32>,
    alpha: Option<f32>,
    /// vpl and lightcuts: light paths per pass and the VPL clamp; lightcuts: error bound;
    /// irradiance-cache: error threshold and gather rays per record.
    light_paths: Option<u32>,
    clamp: Option<f32>,
    error: Option<f32>,
    gather: Option<u32>,
    /// pssmlt: bootstrap samples, chains, large-step probability, small-step deviation.
    bootstrap: Option<u32>,
    chains: Option<u32>,
    large_step: Option<f32>,
    sigma: Option<f32>,
}

impl Default for IntegratorSection {
    fn default() -> Self {
        let p = PathTracer::default();
        Self {
            kind: Integrator::Path.name().into(),
            spp: 16,
            max_depth: p.max_depth,
            rr_depth: p.rr_depth,
            hide_emitters: p.hide_emitters,
            seed: 0,
            photons: None,
            radius: None,
            alpha: None,
            light_paths: None,
            clamp: None,
            error: None,
            gather: None,
            bootstrap: None,
            chains: None,
            large_step: None,
            sigma: None,
        }
    }
}

/// Most light paths per pass a scene may ask the many-light integrators for.
const MAX_LIGHT_PATHS: u32 = 1_000_000;

impl IntegratorSection {
    /// The render settings, or the error `invalid(key, reason)` makes for the first bad key.
    pub(crate) fn settings(
        &self,
        invalid: impl Fn(&str, &str) -> SceneFileError,
    ) -> Result<RenderSettings, SceneFileError> {
        if self.spp == 0 || self.max_depth == 0 {
            return Err(invalid("integrator", "spp and max_depth must be at least 1"));
        }
        let mut integrator = Integrator::from_name(&self.kind).ok_or_else(|| {
            invalid("integrator.type", &format!("unknown integrator {:?} (one of {})", self.kind, Integrator::names()))
        })?;
        let sppm_keys = self.photons.is_some() || self.radius.is_some() || self.alpha.is_some();
        if sppm_keys && !matches!(integrator, Integrator::Sppm(_)) {
            return Err(invalid("integrator", "photons, radius and alpha belong to type = \"sppm\""));
        }
        let vpl_keys = self.light_paths.is_some() || self.clamp.is_some();
        if vpl_keys && !matches!(integrator, Integrator::Vpl(_) | Integrator::Lightcuts(_)) {
            return Err(invalid("integrator", "light_paths and clamp belong to type = \"vpl\" or \"lightcuts\""));
        }
        if self.error.is_some() && !matches!(integrator, Integrator::Lightcuts(_) | Integrator::IrradianceCache(_)) {
            return Err(invalid("integrator", "error belongs to type = \"lightcuts\" or \"irradiance-cache\""));
        }
        let mlt_keys =
            self.bootstrap.is_some() || self.chains.is_some() || self.large_step.is_some() || self.sigma.is_some();
        if mlt_keys && !matches!(integrator, Integrator::Pssmlt(_)) {
            return Err(invalid("integrator", "bootstrap, chains, large_step and sigma belong to type = \"pssmlt\""));
        }
        if self.gather.is_some() && !matches!(integrator, Integrator::IrradianceCache(_)) {
            return Err(invalid("integrator", "gather belongs to type = \"irradiance-cache\""));
        }
        match &mut integrator {
            Integrator::Sppm(params) => {
                if let Some(photons) = self.photons {
                    if photons == 0 || photons > 100_000_000 {
                        return Err(invalid("integrator.photons", "must be in 1..=100000000"));
                    }
                    params.photons = photons;
                }
                if let Some(radius) = self.radius {
                    if !(radius.is_finite() && radius > 0.0) {
                        return Err(invalid("integrator.radius", "must be a positive number"));
                    }
                    params.radius = radius;
                }
                if let Some(alpha) = self.alpha {
                    if !(alpha > 0.0 && alpha < 1.0) {
                        return Err(invalid("integrator.alpha", "must be in (0, 1)"));
                    }
                    params.alpha = alpha;
                }
            }
            Integrator::Vpl(params) => {
                self.vpl_keys(params, 1, &invalid)?;
            }
            Integrator::Lightcuts(params) => {
                self.vpl_keys(&mut params.vpls, 0, &invalid)?;
                if let Some(error) = self.error {
                    if !(0.0..1.0).contains(&error) {
                        return Err(invalid("integrator.error", "must be in [0, 1) (0: sum every light)"));
                    }
                    params.error = error;
                }
            }
            Integrator::IrradianceCache(params) => {
                if let Some(error) = self.error {
                    if !(0.0..=2.0).contains(&error) {
                        return Err(invalid("integrator.error", "must be in [0, 2] (Ward's a; 0: no interpolation)"));
                    }
                    params.error = error;
                }
                if let Some(gather) = self.gather {
                    if !(1..=1_000_000).contains(&gather) {
                        return Err(invalid("integrator.gather", "must be in 1..=1000000"));
                    }
                    params.gather = gather;
                }
            }
            Integrator::Pssmlt(params) => {
                if let Some(n) = self.bootstrap {
                    if n > 100_000_000 {
                        return Err(invalid("integrator.bootstrap", "must be at most 100000000 (0: automatic)"));
                    }
                    params.bootstrap = n;
                }
                if let Some(n) = self.chains {
                    if n > 1_000_000 {
                        return Err(invalid("integrator.chains", "must be at most 1000000 (0: automatic)"));
                    }
                    params.chains = n;
                }
                if let Some(p) = self.large_step {
                    if !(p > 0.0 && p <= 1.0) {
                        return Err(invalid("integrator.large_step", "must be in (0, 1]"));
                    }
                    params.large_step = p;
                }
                if let Some(s) = self.sigma {
                    if !(s > 0.0 && s < 1.0) {
                        return Err(invalid("integrator.sigma", "must be in (0, 1)"));
                    }
                    params.sigma = s;
                }
            }
            _ => {}
        }
        Ok(RenderSettings {
            spp: self.spp,
            seed: self.seed,
            path: PathTracer {
                max_depth: self.max_depth,
                rr_depth: self.rr_depth,
                hide_emitters: self.hide_emitters,
                ..PathTracer::default()
            },
            integrator,
        })
    }

    fn vpl_keys(
        &self,
        params: &mut crate::manylight::InstantRadiosity,
        min_paths: u32,
        invalid: &impl Fn(&str, &str) -> SceneFileError,
    ) -> Result<(), SceneFileError> {
        if let Some(paths) = self.light_paths {
            if !(min_paths..=MAX_LIGHT_PATHS).contains(&paths) {
                return Err(invalid("integrator.light_paths", &format!("must be in {min_paths}..={MAX_LIGHT_PATHS}")));
            }
            params.light_paths = paths;
        }
        if let Some(clamp) = self.clamp {
            if !(clamp.is_finite() && clamp >= 0.0) {
                return Err(invalid("integrator.clamp", "must be a number ≥ 0 (a fraction of the scene's radius)"));
            }
            params.clamp = clamp;
        }
        Ok(())
    }
}
