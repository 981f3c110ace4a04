//! Dual photography (Sen et al. 2005; the reference notes' relighting section): a scene lit by
//! an M × N projector and seen by a camera has a transport matrix `T` whose column `j` is the
//! camera image under projector pixel `j` alone. By Helmholtz reciprocity `Tᵀ` is the
//! transport with camera and projector swapped, so the image the projector would see if the
//! camera were a light is, pixel by pixel, `d_j = Σᵢ T_ij Ωᵢ / Ω_j` (the solid angles of camera
//! pixel `i` and projector pixel `j`: an image's pixel is radiance averaged over its solid
//! angle, and the camera-light sends 1 W/sr through each of its pixels).
//!
//! Measuring `T` one projector pixel at a time takes M·N renders. The adaptive scheme first
//! lights `b × b` blocks of the projector one at a time; a pixel's footprint in the camera
//! (where it puts more than a threshold of light) lies inside its block's, so blocks whose
//! footprints do not overlap can have one pixel each lit in the same render, every camera
//! pixel then belonging to at most one lit pixel. Blocks that light nothing the camera sees
//! are not measured further. Light below the threshold (dim interreflections) is what the
//! scheme gives up.

use glam::Vec3;
use lucid_image::Image;
use lucid_scene::PinholeCamera;
use lucid_trace::light::Light;
use lucid_trace::projector::{Projector, rectangle_solid_angle};
use lucid_trace::{RenderCamera, RenderSettings, Scene, render};

/// How to measure the transport.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DualSettings {
    /// Light groups of pixels whose footprints do not overlap, rather than one at a time.
    pub adaptive: bool,
    /// Side of the projector blocks whose footprints the adaptive scheme measures first.
    pub block: usize,
    /// A camera pixel is in a footprint where it receives more than this share of the
    /// footprint's brightest pixel (max over channels).
    pub threshold: f32,
}

impl Default for DualSettings {
    fn default() -> Self {
        Self { adaptive: false, block: 4, threshold: 0.01 }
    }
}

/// A measured transport and what it gives.
pub struct DualCapture {
    /// The dual image: seen from the projector (its resolution), lit from the camera (1 W/sr).
    pub dual: Image,
    /// The camera's image under the whole projector lit white (1 W/sr): `T` times ones.
    pub primal: Image,
    /// Renders made.
    pub renders: usize,
    /// Renders one pixel at a time would make (M·N).
    pub pixel_renders: usize,
}

/// Solid angle of each pixel of a pinhole camera (row-major).
pub fn camera_pixel_solid_angles(camera: &PinholeCamera) -> Vec<f32> {
    let k = &camera.intrinsics;
    let (w, h) = (k.width as usize, k.height as usize);
    (0..w * h)
        .map(|p| {
            let (i, j) = ((p % w) as f32, (p / w) as f32);
            let a = glam::Vec2::new((i - k.cx) / k.fx, (j - k.cy) / k.fy);
            let b = glam::Vec2::new((i + 1.0 - k.cx) / k.fx, (j + 1.0 - k.cy) / k.fy);
            rectangle_solid_angle(a, b)
        })
        .collect()
}

/// Renders `scene` (its own lights replaced by `projector` showing `lit` pixels white) from
/// `camera`.
fn render_pattern(
    scene: &Scene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    projector: &Projector,
    lit: &[usize],
    seed: u64,
) -> Result<Image, String> {
    let (m, n) = projector.resolution();
    let mut pixels = vec![Vec3::ZERO; m * n];
    for &j in lit {
        pixels[j] = Vec3::ONE;
    }
    let pattern = projector.with_pixels(pixels).ok_or("the projector's pose is degenerate")?;
    let lit_scene = scene.relit(vec![Light::Projector(Box::new(pattern))])?;
    let settings = RenderSettings { seed, ..*settings };
    Ok(render(&lit_scene, &RenderCamera::Pinhole(*camera), &settings, &|_| {}).map_err(|e| e.to_string())?.colour)
}

fn rgb(p: [f32; 4]) -> Vec3 {
    Vec3::new(p[0], p[1], p[2])
}

/// Measures the transport from `projector` to `camera` in `scene` and forms the dual image;
/// `progress` hears of each render (done, planned so far).
pub fn capture(
    scene: &Scene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    projector: &Projector,
    dual: &DualSettings,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<DualCapture, String> {
    let (m, n) = projector.resolution();
    let omega_c = camera_pixel_solid_angles(camera);
    let omega_p: Vec<f32> = (0..m * n).map(|j| projector.pixel_solid_angle(j % m, j / m)).collect();
    let cw = camera.intrinsics.width as usize;
    let ch = camera.intrinsics.height as usize;
    let mut dual_pixels = vec![Vec3::ZERO; m * n];
    let mut primal = vec![Vec3::ZERO; cw * ch];
    let mut renders = 0usize;
    // Every render draws from its own random streams.
    let mut next_seed = {
        let base = settings.seed;
        let mut k = 0u64;
        move || {
            k += 1;
            base ^ (k << 20)
        }
    };
    // Adds the camera pixels `pixels` of `image` to projector pixel `j`'s column.
    let mut attribute = |image: &Image, j: usize, pixels: &mut dyn Iterator<Item = usize>| {
        for i in pixels {
            let c = rgb(image.get(i % cw, i / cw));
            dual_pixels[j] += c * (omega_c[i] / omega_p[j]);
            primal[i] += c;
        }
    };
    if !dual.adaptive {
        for j in 0..m * n {
            let image = render_pattern(scene, camera, settings, projector, &[j], next_seed())?;
            attribute(&image, j, &mut (0..cw * ch));
            renders += 1;
            progress(renders, m * n);
        }
    } else {
        let b = dual.block.max(1);
        let (bm, bn) = (m.div_ceil(b), n.div_ceil(b));
        // The projector pixels of each block (blocks at the right and bottom edges may be
        // smaller).
        let blocks: Vec<Vec<usize>> = (0..bm * bn)
            .map(|k| {
                let (bx, by) = (k % bm, k / bm);
                (by * b..((by + 1) * b).min(n))
                    .flat_map(|y| (bx * b..((bx + 1) * b).min(m)).map(move |x| y * m + x))
                    .collect()
            })
            .collect();
        // Each block's footprint: the camera pixels it lights above the threshold.
        let mut footprints: Vec<Vec<usize>> = Vec::with_capacity(bm * bn);
        for block in &blocks {
            let image = render_pattern(scene, camera, settings, projector, block, next_seed())?;
            renders += 1;
            progress(renders, bm * bn);
            let values: Vec<f32> = (0..cw * ch).map(|i| rgb(image.get(i % cw, i / cw)).max_element()).collect();
            let peak = values.iter().copied().fold(0.0, f32::max);
            footprints.push(if peak > 0.0 {
                (0..cw * ch).filter(|&i| values[i] > dual.threshold * peak).collect()
            } else {
                Vec::new()
            });
        }
        // Greedy grouping, largest footprints first: a block joins the first group none of
        // whose footprints it overlaps.
        let mut order: Vec<usize> = (0..bm * bn).filter(|&k| !footprints[k].is_empty()).collect();
        order.sort_by_key(|&k| std::cmp::Reverse(footprints[k].len()));
        let mut groups: Vec<(Vec<usize>, Vec<bool>)> = Vec::new();
        for k in order {
            let slot = groups.iter().position(|(_, covered)| footprints[k].iter().all(|&i| !covered[i]));
            let (members, covered) = match slot {
                Some(g) => &mut groups[g],
                None => {
                    groups.push((Vec::new(), vec![false; cw * ch]));
                    groups.last_mut().expect("just pushed")
                }
            };
            members.push(k);
            for &i in &footprints[k] {
                covered[i] = true;
            }
        }
        let planned = renders + groups.len() * b * b;
        for (members, _) in &groups {
            for offset in 0..b * b {
                // The pixel at `offset` within each member block (blocks at the edge may be
                // smaller).
                let lit: Vec<(usize, usize)> =
                    members.iter().filter_map(|&k| blocks[k].get(offset).map(|&j| (k, j))).collect();
                if lit.is_empty() {
                    continue;
                }
                let pixels: Vec<usize> = lit.iter().map(|&(_, j)| j).collect();
                let image = render_pattern(scene, camera, settings, projector, &pixels, next_seed())?;
                renders += 1;
                progress(renders, planned);
                for &(k, j) in &lit {
                    attribute(&image, j, &mut footprints[k].iter().copied());
                }
            }
        }
    }
    let dual_image = Image::from_fn(m, n, |x, y| {
        let v = dual_pixels[y * m + x];
        [v.x, v.y, v.z, 1.0]
    });
    let primal_image = Image::from_fn(cw, ch, |x, y| {
        let v = primal[y * cw + x];
        [v.x, v.y, v.z, 1.0]
    });
    Ok(DualCapture { dual: dual_image, primal: primal_image, renders, pixel_renders: m * n })
}

/// PSNR of `a` against `b` on linear values, the peak being `b`'s brightest channel (dual
/// images are radiance, not display values).
pub fn linear_psnr(a: &Image, b: &Image) -> f64 {
    let peak = b.pixels().iter().flat_map(|p| p[..3].iter().copied()).fold(0.0f32, f32::max) as f64;
    let n = (a.pixels().len() * 3) as f64;
    let sum: f64 = a
        .pixels()
        .iter()
        .zip(b.pixels())
        .map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>())
        .sum();
    10.0 * (peak * peak / (sum / n)).log10()
}

/// The image the dual approximates: rendered from the projector's viewpoint (its frustum and
/// resolution) with the camera turned into a white projector of 1 W/sr per pixel.
pub fn reciprocal_render(
    scene: &Scene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    projector: &Projector,
) -> Result<Image, String> {
    let light = Projector::from_camera(camera, Vec3::ONE).ok_or("the camera's pose is degenerate")?;
    let lit_scene = scene.relit(vec![Light::Projector(Box::new(light))])?;
    let camera = RenderCamera::Pinhole(projector.camera());
    Ok(render(&lit_scene, &camera, settings, &|_| {}).map_err(|e| e.to_string())?.colour)
}

#[cfg(test)]
mod tests;
