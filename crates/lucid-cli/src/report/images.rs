//! Images for reports: ground truth, prediction and error map of a view as PNGs beside the
//! page.

use std::path::Path;

use lucid_image::Image;
use lucid_image::color::srgb_decode;

use super::Figure;

/// Error maps show `|a − b|` (mean over RGB, sRGB values) times this, so that a 10 % error
/// is already full scale.
pub const ERROR_GAIN: f32 = 10.0;

/// A perceptually ordered dark-to-bright colour ramp (black, purple, orange, yellow), `t` in
/// `[0, 1]`, as linear RGB for the PNG writer.
fn ramp(t: f32) -> [f32; 3] {
    const STOPS: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [0.45, 0.1, 0.55], [0.95, 0.45, 0.1], [1.0, 1.0, 0.6]];
    let x = t.clamp(0.0, 1.0) * 3.0;
    let i = (x.floor() as usize).min(2);
    let f = x - i as f32;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    [0, 1, 2].map(|c| srgb_decode(a[c] + (b[c] - a[c]) * f))
}

/// The error map between two opaque images of sRGB values.
pub fn error_map(prediction_srgb: &Image, truth_srgb: &Image) -> Image {
    let (w, h) = truth_srgb.dimensions();
    Image::from_fn(w, h, |x, y| {
        let (p, t) = (prediction_srgb.get(x, y), truth_srgb.get(x, y));
        let e = ((p[0] - t[0]).abs() + (p[1] - t[1]).abs() + (p[2] - t[2]).abs()) / 3.0;
        let [r, g, b] = ramp(e * ERROR_GAIN);
        [r, g, b, 1.0]
    })
}

/// Writes `truth | prediction | error` of one view (opaque, sRGB values) as PNGs named
/// `stem_{truth,prediction,error}.png` in `dir` (beside the report) and returns the figures.
pub fn view_triplet(
    dir: &Path,
    folder: &str,
    stem: &str,
    label: &str,
    prediction_srgb: &Image,
    truth_srgb: &Image,
) -> anyhow::Result<Vec<Figure>> {
    let out = dir.join(folder);
    std::fs::create_dir_all(&out)?;
    let linear = |i: &Image| i.map(|p| [srgb_decode(p[0]), srgb_decode(p[1]), srgb_decode(p[2]), 1.0]);
    let mut figures = Vec::new();
    for (kind, image) in [
        ("truth", linear(truth_srgb)),
        ("prediction", linear(prediction_srgb)),
        ("error", error_map(prediction_srgb, truth_srgb)),
    ] {
        let name = format!("{stem}_{kind}.png");
        lucid_image::write_image(out.join(&name), &image)?;
        let caption = match kind {
            "error" => format!("{label}: |error| ×{ERROR_GAIN}"),
            _ => format!("{label}: {kind}"),
        };
        figures.push(Figure { caption, path: format!("{folder}/{name}") });
    }
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_error_map_is_black_where_images_agree_and_bright_where_they_differ() {
        let a = Image::filled(4, 2, [0.5, 0.5, 0.5, 1.0]);
        let mut b = a.clone();
        b.set(1, 1, [0.6, 0.6, 0.6, 1.0]);
        let e = error_map(&b, &a);
        assert_eq!(e.get(0, 0), [0.0, 0.0, 0.0, 1.0]);
        // 0.1 × gain = full scale: the ramp's last stop.
        let top = e.get(1, 1);
        assert!((top[0] - 1.0).abs() < 1e-4 && (top[1] - 1.0).abs() < 1e-4, "{top:?}");
    }
}
