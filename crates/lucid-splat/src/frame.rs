//! Clouds in a dataset's own frame: a capture is trained in normalised coordinates
//! ([`SceneNormalisation`]), and its exported `.ply` is mapped back so that it lines up with
//! the dataset's cameras and SfM points in any viewer.

use glam::{DMat3, DVec3, Quat};
use lucid_scene::dataset::SceneNormalisation;

use crate::cloud::SplatCloud;
use crate::project::SH_REST;
use crate::sh::ShRotation;

/// `cloud` (scene coordinates) in the dataset's coordinates: centres moved, turned and
/// scaled, scales and orientations with them, and the view-dependent colour turned so that
/// every Gaussian shows the same colour along the same (turned) ray.
pub fn cloud_in_dataset_frame(cloud: &SplatCloud, frame: &SceneNormalisation) -> SplatCloud {
    let turn = frame.rotation.inverse();
    let turn32 = turn.as_quat();
    let sh = ShRotation::new(DMat3::from_quat(turn));
    let log_scale = frame.scale.ln() as f32;
    let mut out = cloud.clone();
    for (m, o) in cloud.means.chunks_exact(3).zip(out.means.chunks_exact_mut(3)) {
        let p = frame.to_dataset(DVec3::new(m[0].into(), m[1].into(), m[2].into()));
        o.copy_from_slice(&p.as_vec3().to_array());
    }
    out.log_scales.iter_mut().for_each(|s| *s -= log_scale);
    for q in out.rotations.chunks_exact_mut(4) {
        // Stored (w, x, y, z); glam's order is (x, y, z, w).
        let turned = turn32 * Quat::from_xyzw(q[1], q[2], q[3], q[0]);
        q.copy_from_slice(&[turned.w, turned.x, turned.y, turned.z]);
    }
    out.sh_rest.chunks_exact_mut(SH_REST).for_each(|rest| sh.apply_rest(rest));
    out
}

#[cfg(test)]
mod tests {
    use glam::{DQuat, Vec3};
    use lucid_scene::{Intrinsics, PinholeCamera, look_at};

    use super::*;
    use crate::camera::SplatCamera;
    use crate::project::RenderSettings;
    use crate::render::render;

    /// The exported cloud seen by the dataset's camera is the trained cloud seen by the scene's
    /// camera: colour (with view-dependent SH at degree 3) and depth, which scales with the
    /// frame.
    #[test]
    fn a_view_is_the_same_in_both_frames() {
        let mut cloud = SplatCloud::default();
        for i in 0..60 {
            let t = i as f32 * 0.37;
            let p = Vec3::new(t.sin() * 0.6, (1.7 * t).cos() * 0.5, (0.5 * t).sin() * 0.4);
            cloud.push(p, 0.05 + 0.03 * (t * 2.0).sin().abs(), 0.7, [0.2 + 0.6 * t.sin().abs(), 0.4, 0.8]);
        }
        for (k, v) in cloud.sh_rest.iter_mut().enumerate() {
            *v = (k as f32 * 0.61).sin() * 0.3;
        }
        for (k, q) in cloud.rotations.chunks_exact_mut(4).enumerate() {
            let r = Quat::from_axis_angle(Vec3::new(1.0, k as f32, 0.5).normalize(), k as f32 * 0.4);
            q.copy_from_slice(&[r.w, r.x, r.y, r.z]);
        }
        for (k, s) in cloud.log_scales.iter_mut().enumerate() {
            *s += 0.4 * ((k % 3) as f32 - 1.0);
        }
        let frame = SceneNormalisation {
            centre: DVec3::new(3.0, -7.0, 1.5),
            rotation: DQuat::from_axis_angle(DVec3::new(0.2, 1.0, -0.4).normalize(), 1.1),
            scale: 0.125,
        };
        let exported = cloud_in_dataset_frame(&cloud, &frame);

        let k = Intrinsics::from_fov_x(64, 48, 0.9);
        let scene_camera = PinholeCamera::new(k, look_at(Vec3::new(2.0, -1.5, 1.0), Vec3::ZERO, Vec3::Z));
        let pose = frame.pose_to_dataset(scene_camera.camera_to_world.as_dmat4());
        let dataset_camera = PinholeCamera::new(k, pose.as_mat4());
        let settings = RenderSettings { near: 0.05, ..RenderSettings::default() };
        let far_settings = RenderSettings { near: 0.05 / frame.scale as f32, ..settings };
        let (a, sa) = render(&cloud.params(), &SplatCamera::from_pinhole(&scene_camera), &settings);
        let (b, sb) = render(&exported.params(), &SplatCamera::from_pinhole(&dataset_camera), &far_settings);
        let covered = a.chunks_exact(4).filter(|p| p[3] > 0.1).count();
        assert!(covered > 200, "the view sees the cloud ({covered} pixels)");
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x - y).abs() < 2e-3, "value {i}: {x} vs {y}");
        }
        for (x, y) in sa.pixels.depth.iter().zip(&sb.pixels.depth) {
            assert!((x / frame.scale as f32 - y).abs() < 1e-3 * y.abs().max(1.0), "depth {x} vs {y}");
        }
        // Round trip of the pose helpers.
        let back = frame.pose_to_scene(pose);
        assert!(back.abs_diff_eq(scene_camera.camera_to_world.as_dmat4(), 1e-5));
    }
}
