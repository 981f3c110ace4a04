//! Captures end to end: `lucid gen garden --rig capture` writes photographs and a COLMAP model
//! that Lucid (and COLMAP's conventions) read back as the scene that was rendered, and the
//! trainers learn the unbounded scene from it.

use std::path::Path;

use glam::Vec2;
use lucid_scene::{Camera, Dataset, Split};
use lucid_tests::{lucid_in, temp_dir};

fn capture(d: &Path, name: &str, extra: &[&str]) {
    let args = [
        &["gen", "garden", "--rig", "capture", "-o", name, "--res", "64", "--height", "48"][..],
        &["--images", "16", "--spp", "4", "--points", "3000", "-q"][..],
        extra,
    ]
    .concat();
    lucid_in(d, &args).success();
}

#[test]
fn a_generated_capture_reads_back_as_the_scene_rendered() {
    let dir = temp_dir();
    let d = dir.path();
    capture(d, "cap", &["--k1", "-0.06"]);
    assert!(d.join("cap/sparse/0/cameras.bin").is_file() && d.join("cap/images/img_0015.png").is_file());
    let ds = Dataset::open(d.join("cap")).unwrap();
    let names: Vec<&str> = ds.frames(Split::Test).iter().map(|f| f.file_path.as_str()).collect();
    assert_eq!(names, ["img_0000.png", "img_0008.png"], "every 8th photograph is held out");
    assert_eq!(ds.frames(Split::Train).len(), 14);
    let k = ds.frames(Split::Train)[0].camera.intrinsics;
    assert_eq!(k.distortion, lucid_scene::LensDistortion::opencv(-0.06, 0.0, 0.0, 0.0));
    assert!(ds.points.len() > 500, "{} sparse points", ds.points.len());
    // Each point sits on a surface that at least three photographs saw: where it projects
    // into them, their rendered depth is the point's own depth. A pose, lens or
    // normalisation read wrongly would leave points floating off every surface.
    let n = ds.normalisation.unwrap();
    let to_dataset = |q: glam::Vec3| n.to_dataset(q.as_dvec3());
    let views: Vec<_> = ds
        .all_frames()
        .map(|f| {
            let name = f.file_path.trim_end_matches(".png");
            let depth = lucid_image::read_image(d.join(format!("cap/depth/{name}.exr"))).unwrap();
            let eye = to_dataset(f.camera.position());
            let axis = (to_dataset(f.camera.position() + f.camera.forward()) - eye).normalize();
            (f.camera, depth, eye, axis)
        })
        .collect();
    for p in ds.points.iter().step_by(5) {
        let seen_by = views
            .iter()
            .filter(|(camera, depth, eye, axis)| {
                let Some(uv) = camera.project(p.position) else { return false };
                if uv.x < 0.0 || uv.y < 0.0 || uv.x >= 64.0 || uv.y >= 48.0 {
                    return false;
                }
                let seen = f64::from(depth.get(uv.x as usize, uv.y as usize)[0]);
                let z = (to_dataset(p.position) - *eye).dot(*axis);
                (seen - z).abs() < 0.01 * z
            })
            .count();
        assert!(seen_by >= 3, "a point at {} is on a surface in {seen_by} photographs", p.position);
    }
    // And the rays through those pixels pass through the points (lens and pose agree).
    let f = &ds.frames(Split::Train)[3];
    for p in ds.points.iter().take(200) {
        let Some(uv) =
            f.camera.project(p.position).filter(|uv| uv.cmpge(Vec2::ZERO).all() && uv.x < 64.0 && uv.y < 48.0)
        else {
            continue;
        };
        let ray = f.camera.generate_ray(uv.x, uv.y, Vec2::ZERO);
        let t = (p.position - ray.origin).dot(ray.direction);
        assert!((ray.at(t) - p.position).length() < 1e-4 * t.max(1.0));
    }
}
