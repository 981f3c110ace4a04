//! The demo's visual outputs and its HTML report: held-out PSNR curves over training time,
//! ground truth / prediction / error of a few test views, a novel-view orbit and a refocused
//! view per model, and the tables of numbers, timings, machine and settings.

use std::path::Path;

use glam::{Vec3, Vec4Swizzles};
use lucid_image::Image;
use lucid_scene::dataset::images::ImageSet;
use lucid_scene::evaluation::{EvalSummary, ViewModel, evaluate};
use lucid_scene::{PinholeCamera, look_at};

use crate::report::images::view_triplet;
use crate::report::machine::MachineInfo;
use crate::report::plot::{Series, line_plot};
use crate::report::{Figure, Report};

/// Test views whose PSNR is tracked during training (a cheap held-out curve).
pub const CURVE_VIEWS: usize = 2;
/// Test views shown as truth / prediction / error.
const SHOWN_VIEWS: usize = 3;
/// Frames of the novel-view orbit.
const ORBIT_FRAMES: usize = 6;
/// Rays per pixel over the aperture of the refocused view.
const LENS_RAYS: usize = 32;

/// Everything the report shows about one trained model.
pub struct ModelRun {
    /// Display name.
    pub name: &'static str,
    /// Steps trained.
    pub steps: usize,
    /// Training seconds (curve evaluations excluded).
    pub seconds: f64,
    /// Scores on all test views.
    pub summary: EvalSummary,
    /// The checkpoint.
    pub checkpoint: std::path::PathBuf,
    /// `(training seconds, held-out PSNR on the first test views)`.
    pub curve: Vec<(f64, f64)>,
    /// Truth / prediction / error triplets.
    pub views: Vec<Figure>,
    /// Novel views around the object, then a refocused one.
    pub novel: Vec<Figure>,
}

/// Mean PSNR of `renderer` on the first [`CURVE_VIEWS`] views of `test`.
pub fn held_out_psnr(renderer: &dyn ViewModel, test: &ImageSet) -> f64 {
    evaluate(renderer, test, Some(CURVE_VIEWS), |_, _, _, _| {}).1.psnr
}

/// Scores `renderer` on every test view, writing each render as `dir/test_NNN.png`, and the
/// first views' truth / prediction / error beside the report (`report_dir/images`).
pub fn score_and_show(
    renderer: &dyn ViewModel,
    test: &ImageSet,
    dir: &Path,
    report_dir: &Path,
    name: &str,
) -> anyhow::Result<(EvalSummary, Vec<Figure>)> {
    let mut failure: Option<anyhow::Error> = None;
    let mut figures = Vec::new();
    let (_, summary) = evaluate(renderer, test, None, |i, view, truth, score| {
        let mut work = || -> anyhow::Result<()> {
            lucid_image::write_image(dir.join(format!("test_{i:03}.png")), &view.linear_colour())?;
            if i < SHOWN_VIEWS {
                let prediction = view.colour.map(|p| [p[0], p[1], p[2], 1.0]);
                let label = format!("{name} view {i} ({:.2} dB)", score.psnr);
                let stem = format!("{}_view{i}", name.to_lowercase());
                figures.extend(view_triplet(report_dir, "images", &stem, &label, &prediction, truth)?);
            }
            Ok(())
        };
        if let Err(e) = work() {
            failure.get_or_insert(e);
        }
    });
    match failure {
        Some(e) => Err(e),
        None => Ok((summary, figures)),
    }
}

/// Orbit cameras around the origin at the test cameras' mean distance, 30° up, with the
/// first test view's intrinsics.
fn orbit(test: &ImageSet) -> Vec<PinholeCamera> {
    let k = test.cameras[0].intrinsics;
    let radius =
        test.cameras.iter().map(|c| c.camera_to_world.w_axis.xyz().length()).sum::<f32>() / test.cameras.len() as f32;
    let elevation = 30f32.to_radians();
    (0..ORBIT_FRAMES)
        .map(|i| {
            let azimuth = std::f32::consts::TAU * i as f32 / ORBIT_FRAMES as f32;
            let dir = Vec3::new(elevation.cos() * azimuth.cos(), elevation.cos() * azimuth.sin(), elevation.sin());
            PinholeCamera::new(k, look_at(dir * radius, Vec3::ZERO, Vec3::Z))
        })
        .collect()
}

/// Renders the orbit and a refocused view (thin lens focused on the origin, aperture radius
/// 0.15) beside the report.
pub fn novel_views(
    renderer: &dyn ViewModel,
    test: &ImageSet,
    report_dir: &Path,
    name: &str,
) -> anyhow::Result<Vec<Figure>> {
    let out = report_dir.join("images");
    std::fs::create_dir_all(&out)?;
    let key = name.to_lowercase();
    let mut figures = Vec::new();
    let save = |image: &Image, file: String| -> anyhow::Result<String> {
        lucid_image::write_image(out.join(&file), image)?;
        Ok(format!("images/{file}"))
    };
    for (i, camera) in orbit(test).iter().enumerate() {
        let view = renderer.render_view(camera, None, 1, i as u64);
        let path = save(&view.linear_colour(), format!("{key}_orbit{i}.png"))?;
        figures.push(Figure { caption: format!("{name} orbit {}°", 360 * i / ORBIT_FRAMES), path });
    }
    let camera = test.cameras[0];
    let focus = camera.camera_to_world.w_axis.xyz().length();
    let view = renderer.render_view(&camera, Some((0.15, focus)), LENS_RAYS, 7);
    let path = save(&view.linear_colour(), format!("{key}_refocused.png"))?;
    figures.push(Figure { caption: format!("{name} refocused at {focus:.1} (aperture 0.15)"), path });
    Ok(figures)
}

/// What the report says about the dataset and baselines.
pub struct DemoFacts<'a> {
    /// Image side.
    pub size: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Views per split.
    pub views: [usize; 3],
    /// Seed.
    pub seed: u64,
    /// Seconds spent generating the dataset.
    pub generation_seconds: f64,
    /// Whole run.
    pub total_seconds: f64,
    /// 8-bit PNG vs HDR truth.
    pub quantisation: (f64, f64),
    /// Nearest training view.
    pub nearest: (f64, f64),
    /// The dataset folder.
    pub dataset: &'a Path,
}

/// Writes `report_dir/report.html`.
pub fn write_report(facts: &DemoFacts, runs: &[ModelRun], report_dir: &Path) -> anyhow::Result<std::path::PathBuf> {
    let mut r = Report::new("Lucid demo: the object scene, generated, trained and evaluated on a CPU");
    let [train, val, test] = facts.views;
    r.heading("Dataset").table(
        &["property", "value"],
        &[
            vec!["scene".into(), "object (built in), path-traced".into()],
            vec!["folder".into(), facts.dataset.display().to_string()],
            vec!["images".into(), format!("{0}×{0} pixels, {1} samples per pixel", facts.size, facts.spp)],
            vec!["views".into(), format!("{train} train / {val} val / {test} test")],
            vec!["seed".into(), facts.seed.to_string()],
            vec!["generation".into(), format!("{:.1} s", facts.generation_seconds)],
        ],
    );
    r.heading("Held-out test views").note(
        "PSNR and SSIM on sRGB values over a white background, every test view. The first two rows bound \
         the problem: 8-bit quantisation alone, and the nearest training view as a prediction.",
    );
    let mut rows = vec![
        vec![
            "8-bit PNG vs HDR truth".into(),
            format!("{:.2}", facts.quantisation.0),
            format!("{:.4}", facts.quantisation.1),
            "".into(),
            "".into(),
            "".into(),
        ],
        vec![
            "nearest training view".into(),
            format!("{:.2}", facts.nearest.0),
            format!("{:.4}", facts.nearest.1),
            "".into(),
            "".into(),
            "".into(),
        ],
    ];
    for m in runs {
        rows.push(vec![
            m.name.into(),
            format!("{:.2}", m.summary.psnr),
            format!("{:.4}", m.summary.ssim),
            m.steps.to_string(),
            format!("{:.1}", m.seconds),
            format!("{:.3}", m.summary.seconds_per_view),
        ]);
    }
    r.table(&["method", "PSNR (dB)", "SSIM", "steps", "training (s)", "render (s/view)"], &rows);
    if runs.iter().any(|m| !m.curve.is_empty()) {
        let series: Vec<Series> =
            runs.iter().map(|m| Series { name: m.name.into(), points: m.curve.clone() }).collect();
        let svg = line_plot(
            &format!("Held-out PSNR of the first {CURVE_VIEWS} test views"),
            "training time (s)",
            "PSNR (dB)",
            &series,
            (560, 360),
        )?;
        r.heading("Training curves").plots(&[svg]);
    }
    for m in runs {
        r.heading(&format!("{}: test views", m.name));
        for triplet in m.views.chunks(3) {
            r.figures(triplet);
        }
        r.heading(&format!("{}: novel views", m.name)).figures(&m.novel);
    }
    r.heading("Timing").table(
        &["stage", "seconds"],
        &std::iter::once(vec!["dataset generation".to_string(), format!("{:.1}", facts.generation_seconds)])
            .chain(runs.iter().map(|m| vec![format!("{} training", m.name), format!("{:.1}", m.seconds)]))
            .chain(std::iter::once(vec!["whole demo".to_string(), format!("{:.1}", facts.total_seconds)]))
            .collect::<Vec<_>>(),
    );
    r.heading("Machine").table(&["", ""], &MachineInfo::read().rows());
    let path = report_dir.join("report.html");
    r.write(&path)?;
    Ok(path)
}
