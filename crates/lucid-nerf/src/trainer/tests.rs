use super::*;

#[test]
fn training_rays_pass_through_the_pixel_centre_or_a_point_of_its_area() {
    let pose = lucid_scene::camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y);
    let camera = PinholeCamera::new(lucid_scene::camera::Intrinsics::from_fov_x(64, 48, 0.7), pose);
    let mut rng = Rng::new(3, 4);
    let centre = camera.generate_ray(10.5, 20.5, Vec2::ZERO);
    let ray = training_ray(&camera, 10, 20, (0, 1), false, &mut rng);
    assert_eq!((ray.origin, ray.direction), (centre.origin, centre.direction));
    // Jittered rays spread over the pixel: their directions span about one pixel's angle
    // around the centre's and never more.
    let pixel = camera.generate_ray(11.5, 20.5, Vec2::ZERO).direction.angle_between(centre.direction);
    let mut widest = 0f32;
    for _ in 0..200 {
        let ray = training_ray(&camera, 10, 20, (0, 1), true, &mut rng);
        widest = widest.max(ray.direction.angle_between(centre.direction));
    }
    assert!(widest > 0.5 * pixel && widest <= 0.71 * pixel + 1e-6, "{widest} vs pixel {pixel}");
}

#[test]
fn a_pixels_rays_each_pass_through_their_own_cell_of_it() {
    let pose = lucid_scene::camera::look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y);
    let camera = PinholeCamera::new(lucid_scene::camera::Intrinsics::from_fov_x(64, 48, 0.7), pose);
    let world_to_camera = camera.camera_to_world.inverse();
    // Where a ray crosses the image plane, in pixels.
    let image_point =
        |ray: Ray| camera.intrinsics.project(world_to_camera.transform_point3(ray.origin + ray.direction)).unwrap();
    let mut rng = Rng::new(5, 6);
    for jitter in [false, true] {
        for j in 0..9 {
            for _ in 0..20 {
                let p = image_point(training_ray(&camera, 10, 20, (j, 9), jitter, &mut rng)) - Vec2::new(10.0, 20.0);
                let cell = Vec2::new((j % 3) as f32, (j / 3) as f32) / 3.0;
                let inside = p - cell;
                assert!(inside.min_element() >= -1e-3 && inside.max_element() <= 1.0 / 3.0 + 1e-3, "{j}: {p}");
                if !jitter {
                    assert!((inside - Vec2::splat(1.0 / 6.0)).length() < 1e-3, "{j}: {p} is not its cell's centre");
                }
            }
        }
    }
}

#[test]
fn rows_are_gathered_across_rounds_by_their_overall_index() {
    // Rounds of 2, 0 and 3 rows of width 2; row i holds (i, -i).
    let rounds = vec![vec![0.0, -0.0, 1.0, -1.0], vec![], vec![2.0, -2.0, 3.0, -3.0, 4.0, -4.0]];
    let indices: Vec<u32> = (0..3000).map(|k| (k * 7 % 5) as u32).collect();
    let out = gather_round_rows(&rounds, 2, &indices);
    for (row, &i) in out.chunks(2).zip(&indices) {
        assert_eq!(row, [i as f32, -(i as f32)]);
    }
}

#[test]
fn timings_come_back_from_their_names() {
    let t =
        StepTimings { occupancy: 1.0, march: 2.0, cut: 2.5, field: 3.0, composite: 4.0, backward: 5.0, optimizer: 6.0 };
    let mut named = t.named().to_vec();
    named.push(("elsewhere", 9.0));
    let back = StepTimings::from_named(&named);
    assert_eq!(back.named(), t.named());
}

/// The batch and the learning rate follow the run's progress: the batch geometrically
/// from `batch_samples` to `batch_growth` times it, the rate from `learning_rate` down to
/// its final fraction.
#[test]
fn batch_and_learning_rate_follow_the_budget() {
    let mut config = NerfConfig::default();
    config.train.batch_samples = 1 << 14;
    config.train.batch_growth = 4.0;
    config.train.learning_rate = 0.01;
    config.train.final_learning_rate = 0.1;
    config.occupancy.resolution = 8;
    let device = crate::backend::training_device();
    let mut trainer = NerfTrainer::new(config, (Vec3::splat(-1.0), Vec3::ONE), 1e-3, device);
    for (progress, batch, lr) in [(0.0, 1 << 14, 0.01), (0.5, 1 << 15, 0.01 * 0.1f64.sqrt()), (1.0, 1 << 16, 0.001)] {
        trainer.progress = progress;
        assert_eq!(trainer.batch_samples(), batch, "progress {progress}");
        assert!((trainer.learning_rate() - lr).abs() < 1e-12, "progress {progress}");
    }
    // Beyond the budget (a resumed run) the schedule holds its end.
    trainer.progress = 1.5;
    assert_eq!(trainer.batch_samples(), 1 << 16);
}

/// Views are marched at `march.render_step_scale` of the training steps, everywhere along
/// the ray (the clamps and the cone); training keeps its own.
#[test]
fn views_are_marched_at_the_render_step_scale() {
    let mut config = NerfConfig::default();
    config.occupancy.resolution = 8;
    config.march.render_step_scale = 0.25;
    let device = crate::backend::training_device();
    let trainer = NerfTrainer::new(config, (Vec3::splat(-1.0), Vec3::ONE), 1e-3, device);
    let model = trainer.eval_model();
    let renderer = trainer.renderer(&model);
    for t in [0.01, 1.0, 3.0, 50.0] {
        let (train, view) = (trainer.marcher().step(t), renderer.marcher.step(t));
        assert!((view - 0.25 * train).abs() <= 1e-6 * train, "t {t}: {view} against {train}");
    }
}
