//! The burn op wires the kernels' gradients to the right parameters (the kernels themselves
//! are checked against finite differences in `finite_diff.rs`).

use burn::tensor::{Tensor, TensorData};
use glam::Vec3;
use lucid_burn::backend::training_device;
use lucid_scene::Intrinsics;
use lucid_scene::camera::{PinholeCamera, look_at};
use lucid_splat::ops::{SplatRenderArgs, SplatTensors, render_splats};
use lucid_splat::{RenderSettings, SplatCamera, SplatCloud, render, render_backward};

#[test]
fn gradients_reach_every_parameter() {
    let mut cloud = SplatCloud::default();
    for i in 0..8 {
        let t = i as f32 / 8.0 * std::f32::consts::TAU;
        cloud.push(Vec3::new(0.3 * t.cos(), 0.3 * t.sin(), 0.1 * i as f32 - 0.3), 0.12, 0.6, [0.2, 0.5, 0.8]);
    }
    for (k, v) in cloud.sh_rest.iter_mut().enumerate() {
        *v = 0.02 * ((k % 7) as f32 - 3.0);
    }
    let cam = SplatCamera::from_pinhole(&PinholeCamera::new(
        Intrinsics::from_fov_x(48, 32, 0.8),
        look_at(Vec3::new(2.0, 1.0, 0.5), Vec3::ZERO, Vec3::Z),
    ));
    let settings = RenderSettings::default();
    let (h, w) = (cam.height as usize, cam.width as usize);
    let weights: Vec<f32> = (0..h * w * 4).map(|k| ((k * 31 % 17) as f32 - 8.0) / 8.0).collect();

    // Host reference.
    let (image, state) = render(&cloud.params(), &cam, &settings);
    let want = render_backward(&cloud.params(), &state, &weights);

    let device = training_device();
    let n = cloud.len();
    let param =
        |v: &[f32], cols: usize| Tensor::<2>::from_data(TensorData::new(v.to_vec(), [n, cols]), &device).require_grad();
    let t = SplatTensors {
        means: param(&cloud.means, 3),
        log_scales: param(&cloud.log_scales, 3),
        rotations: param(&cloud.rotations, 4),
        opacities: param(&cloud.opacities, 1),
        sh_dc: param(&cloud.sh_dc, 3),
        sh_rest: param(&cloud.sh_rest, 45),
    };
    let means_2d = Tensor::<2>::zeros([n, 2], &device).require_grad();
    let out = render_splats(&t, means_2d.clone(), SplatRenderArgs::new(cam, settings));
    assert_eq!(out.dims(), [h, w, 4]);
    assert_eq!(out.clone().into_data().try_to_vec::<f32>().unwrap(), image);
    let wt = Tensor::<3>::from_data(TensorData::new(weights, [h, w, 4]), &device);
    let grads = (out * wt).sum().backward();
    let get = |t: &Tensor<2>| t.grad(&grads).expect("a gradient").into_data().try_to_vec::<f32>().unwrap();
    assert_eq!(get(&t.means), want.means);
    assert_eq!(get(&t.log_scales), want.log_scales);
    assert_eq!(get(&t.rotations), want.rotations);
    assert_eq!(get(&t.opacities), want.opacities);
    assert_eq!(get(&t.sh_dc), want.sh_dc);
    assert_eq!(get(&t.sh_rest), want.sh_rest);
    assert_eq!(get(&means_2d), want.means_2d);
    assert!(want.means_2d.iter().any(|g| g.abs() > 1e-6));
}
