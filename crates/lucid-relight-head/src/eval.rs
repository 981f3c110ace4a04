//! Evaluation on held-out views: every OLAT frame of a view (a novel view under each light)
//! and every environment truth (a novel view under a novel environment), against the path
//! tracer's images, by PSNR and SSIM on sRGB values over black (as `lucid relight` scores).

use std::path::PathBuf;

use burn::tensor::Device;
use glam::Vec3;
use lucid_image::Image;
use lucid_image::metrics::{MetricSpace, prepare_for_metrics, psnr, ssim};
use lucid_relight::RelightError;
use lucid_relight::transport::{Weighting, light_weights};
use lucid_relight::voronoi::fibonacci_directions;
use serde::Serialize;

use crate::config::RelightConfig;
use crate::data::CapturedView;
use crate::head::RelightHead;
use crate::render::{Geometry, integrated_radiance, to_image};

/// Scores of one rendered frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameScore {
    /// The view's index in the split.
    pub view: usize,
    /// The truth's file.
    pub truth: PathBuf,
    /// The environment map, for environment frames.
    pub environment: Option<PathBuf>,
    /// Lit by a light that was not among the training lights.
    pub held_out_light: bool,
    /// PSNR, dB.
    pub psnr: f64,
    /// SSIM.
    pub ssim: f64,
}

/// Means over a set of frames.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct MeanScore {
    /// Frames.
    pub frames: usize,
    /// Mean PSNR, dB (`None` without frames).
    pub psnr: Option<f64>,
    /// Mean SSIM (`None` without frames).
    pub ssim: Option<f64>,
}

/// The evaluation of a split.
#[derive(Clone, Debug, Serialize)]
pub struct RelightReport {
    /// Novel views under single training lights.
    pub lights: MeanScore,
    /// Novel views under single held-out lights.
    pub held_out_lights: MeanScore,
    /// Novel views under environment maps.
    pub environments: MeanScore,
    /// Every frame.
    pub frames: Vec<FrameScore>,
    /// Directions the environments were integrated over.
    pub environment_directions: usize,
    /// Seconds per environment render.
    pub seconds_per_environment: f64,
}

fn mean(scores: &[&FrameScore]) -> MeanScore {
    let n = scores.len() as f64;
    let average = |f: fn(&FrameScore) -> f64| (n > 0.0).then(|| scores.iter().map(|s| f(s)).sum::<f64>() / n);
    MeanScore { frames: scores.len(), psnr: average(|s| s.psnr), ssim: average(|s| s.ssim) }
}

/// `(PSNR, SSIM)` of a render against the truth, both straight alpha, on sRGB over black.
pub fn score(render: &Image, truth: &Image) -> Result<(f64, f64), RelightError> {
    let prep = |i: &Image| prepare_for_metrics(i, [0.0; 3], MetricSpace::Srgb);
    let (a, b) = (prep(render), prep(truth));
    let metric = |e: lucid_image::metrics::MetricError| RelightError::Invalid(e.to_string());
    Ok((psnr(&a, &b, None).map_err(metric)?, ssim(&a, &b, None).map_err(metric)?))
}

/// A trained model ready to render.
pub struct RelightModel<'a> {
    /// The configuration.
    pub config: &'a RelightConfig,
    /// The frozen geometry.
    pub geometry: &'a Geometry,
    /// The head.
    pub head: &'a RelightHead,
    /// The training lights' directions (the environment integration's set when
    /// `environment.directions` is 0).
    pub training_directions: &'a [Vec3],
    /// Irradiance of one OLAT light of the training set.
    pub irradiance: f32,
    /// The device the tensors are on.
    pub device: &'a Device,
}

impl RelightModel<'_> {
    /// The directions environments are integrated over.
    pub fn environment_directions(&self) -> Vec<Vec3> {
        match self.config.environment.directions {
            0 => self.training_directions.to_vec(),
            n => fibonacci_directions(n),
        }
    }

    /// The view from `camera` under one light from `direction` (of the training lights'
    /// irradiance).
    pub fn render_light(&self, camera: &lucid_scene::PinholeCamera, direction: Vec3) -> Image {
        let dirs = self.geometry.view_directions(camera);
        let colours = self.head.radiance(self.config, &dirs, direction.normalize(), self.device);
        to_image(self.geometry.render(colours, camera))
    }

    /// The view from `camera` under an environment map (lat-long, linear).
    pub fn render_environment(
        &self,
        camera: &lucid_scene::PinholeCamera,
        env: &Image,
        directions: &[Vec3],
    ) -> Result<Image, RelightError> {
        let weights = light_weights(directions, self.irradiance, env, Weighting::Barycentric)?;
        Ok(self.render_weighted(camera, directions, &weights))
    }

    /// The view from `camera` under light from `directions` with per-channel `weights` (units
    /// of one training light).
    pub fn render_weighted(
        &self,
        camera: &lucid_scene::PinholeCamera,
        directions: &[Vec3],
        weights: &[[f32; 3]],
    ) -> Image {
        let colours =
            integrated_radiance(self.head, self.config, self.geometry, camera, directions, weights, self.device);
        to_image(self.geometry.render(colours, camera))
    }

    /// Renders and scores every frame of `views`; `keep` receives each render with its
    /// score.
    pub fn evaluate(
        &self,
        views: &[CapturedView],
        mut keep: impl FnMut(&FrameScore, &Image) -> Result<(), RelightError>,
    ) -> Result<RelightReport, RelightError> {
        let directions = self.environment_directions();
        // Each map is read and turned into light weights once, not once per view.
        let mut weights: Vec<(&std::path::Path, Vec<[f32; 3]>)> = Vec::new();
        let mut frames = Vec::new();
        let mut env_seconds = 0.0;
        for (v, view) in views.iter().enumerate() {
            for lit in &view.lights {
                let render = self.render_light(&view.camera, lit.direction);
                let truth = lucid_image::read_image(&lit.path)?;
                let (psnr, ssim) = score(&render, &truth)?;
                let s = FrameScore {
                    view: v,
                    truth: lit.path.clone(),
                    environment: None,
                    held_out_light: lit.held_out,
                    psnr,
                    ssim,
                };
                keep(&s, &render)?;
                frames.push(s);
            }
            for truth in &view.environments {
                let k = match weights.iter().position(|(p, _)| *p == truth.environment.as_path()) {
                    Some(k) => k,
                    None => {
                        let env = lucid_image::read_image(&truth.environment)?;
                        let w = light_weights(&directions, self.irradiance, &env, Weighting::Barycentric)?;
                        weights.push((&truth.environment, w));
                        weights.len() - 1
                    }
                };
                let start = std::time::Instant::now();
                let render = self.render_weighted(&view.camera, &directions, &weights[k].1);
                env_seconds += start.elapsed().as_secs_f64();
                let (psnr, ssim) = score(&render, &truth.image)?;
                let s = FrameScore {
                    view: v,
                    truth: truth.path.clone(),
                    environment: Some(truth.environment.clone()),
                    held_out_light: false,
                    psnr,
                    ssim,
                };
                keep(&s, &render)?;
                frames.push(s);
            }
        }
        let lights: Vec<&FrameScore> = frames.iter().filter(|s| s.environment.is_none() && !s.held_out_light).collect();
        let held_out: Vec<&FrameScore> = frames.iter().filter(|s| s.held_out_light).collect();
        let envs: Vec<&FrameScore> = frames.iter().filter(|s| s.environment.is_some()).collect();
        Ok(RelightReport {
            lights: mean(&lights),
            held_out_lights: mean(&held_out),
            environments: mean(&envs),
            seconds_per_environment: env_seconds / envs.len().max(1) as f64,
            environment_directions: directions.len(),
            frames,
        })
    }
}

impl RelightReport {
    /// The report as a table, one line each.
    pub fn lines(&self) -> Vec<String> {
        let mut lines =
            vec![format!("{:<34} {:>7} {:>10} {:>8}", "held-out views under", "frames", "PSNR (dB)", "SSIM")];
        for (label, m) in [
            ("single training lights", &self.lights),
            ("single held-out lights", &self.held_out_lights),
            ("environment maps", &self.environments),
        ] {
            if let (Some(psnr), Some(ssim)) = (m.psnr, m.ssim) {
                lines.push(format!("{label:<34} {:>7} {psnr:>10.2} {ssim:>8.4}", m.frames));
            }
        }
        let mut envs: Vec<&PathBuf> = self.frames.iter().filter_map(|f| f.environment.as_ref()).collect();
        envs.sort();
        envs.dedup();
        for env in envs {
            let s: Vec<f64> =
                self.frames.iter().filter(|f| f.environment.as_ref() == Some(env)).map(|f| f.psnr).collect();
            lines.push(format!(
                "  {:<32} {:>7} {:>10.2}",
                env.display(),
                s.len(),
                s.iter().sum::<f64>() / s.len() as f64
            ));
        }
        if self.environments.frames > 0 {
            lines.push(format!(
                "environments integrated over {} directions, {:.2} s per render",
                self.environment_directions, self.seconds_per_environment
            ));
        }
        lines
    }
}

/// Evaluates a trained head on `views` (their lights and environment maps), writing each
/// render as `VVV_<truth stem>.exr` and `metrics.json` into `out`.
pub fn evaluate_into(
    trained: &crate::checkpoint::TrainedRelight,
    views: &[CapturedView],
    out: &std::path::Path,
    device: &Device,
) -> Result<RelightReport, RelightError> {
    let folder = lucid_image::owned_folder::OwnedFolder::claim(out, "the evaluation", &[])
        .map_err(lucid_image::ImageError::from)?;
    let model = RelightModel {
        config: &trained.header.config,
        geometry: &trained.geometry,
        head: &trained.head,
        training_directions: &trained.lights.directions,
        irradiance: trained.lights.irradiance,
        device,
    };
    let report = model.evaluate(views, |score, image| {
        let stem = score.truth.file_stem().and_then(|s| s.to_str()).unwrap_or("frame");
        let name = format!("{:03}_{}.exr", score.view, stem.trim_end_matches(".exr"));
        Ok(lucid_image::write_image(out.join(name), image)?)
    })?;
    let text = serde_json::to_string_pretty(&report).expect("serialises");
    lucid_image::output::write_text(&out.join("metrics.json"), &text)?;
    folder.finish().map_err(lucid_image::ImageError::from)?;
    Ok(report)
}
