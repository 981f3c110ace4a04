//! `lucid train itm` and `lucid eval` on an ITM checkpoint: a short training run on the
//! bracket frames of two generated scenes beats the analytic baseline on their held-out
//! views, and bad input is refused.

use lucid_tests::{lucid_in, temp_dir};

fn clipped_log_psnr(metrics: &serde_json::Value, method: &str) -> f64 {
    metrics[method]["log_psnr_clipped"].as_f64().expect("a number")
}

/// Trained on two scenes, scored on their held-out views and on a third scene it never saw,
/// against the strongest analytic baseline: the highlight boost (0, the inverse response
/// alone, included) that is best on the training views.
#[test]
fn short_training_beats_the_strongest_analytic_baseline_on_an_unseen_scene() {
    let dir = temp_dir();
    let d = dir.path();
    for scene in ["studio", "spheres", "object"] {
        let out = format!("br_{scene}");
        lucid_in(
            d,
            &["gen", scene, "--rig", "brackets", "--views", "6,0,2", "--res", "64", "--spp", "8", "-o", &out, "-q"],
        )
        .success();
    }
    lucid_in(
        d,
        &["train", "itm", "br_studio", "br_spheres", "-o", "itm", "--steps", "150", "--set", "train.patch=32", "-q"],
    )
    .success();
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("itm/eval_test/metrics.json")).unwrap()).unwrap();
    let (net, base) = (clipped_log_psnr(&metrics, "network"), clipped_log_psnr(&metrics, "analytic"));
    let plain = clipped_log_psnr(&metrics, "inverse_response");
    println!("seen scenes: network {net:.2} dB, analytic {base:.2} dB, inverse response {plain:.2} dB");
    // Measured after 150 steps: network 30.19 dB, analytic (1 EV, chosen on the training
    // views) 29.79, inverse response 25.28; steps, not seconds, so only the CPU's SIMD width
    // can move them. Against the strongest baseline the network's lead is small: 0.4 dB here,
    // 1.2 dB after 600 steps.
    assert!(net >= base + 0.3, "network {net} vs analytic {base}");
    assert!(net > 29.5, "network {net}");
    // `lucid eval` on a scene the network never saw.
    let eval = lucid_in(d, &["eval", "itm/checkpoint.lucid", "br_object", "--json", "-o", "ev"]).success();
    let unseen = eval.json();
    let (net, base) = (clipped_log_psnr(&unseen, "network"), clipped_log_psnr(&unseen, "analytic"));
    println!("unseen scene: network {net:.2} dB, analytic {base:.2} dB ({} EV)", unseen["analytic_boost_stops"]);
    // Measured: network 29.97 dB, analytic (1 EV) 29.36, inverse response 26.26.
    assert!(net >= base + 0.5, "unseen scene: network {net} vs analytic {base}");
    assert!(d.join("ev/000_network.exr").is_file() && d.join("ev/000_truth.exr").is_file());
}

#[test]
fn bad_itm_input_is_refused_clearly() {
    let dir = temp_dir();
    let d = dir.path();
    lucid_in(d, &["gen", "studio", "--views", "2,0,1", "--res", "16", "--spp", "1", "-o", "plain", "-q"]).success();
    lucid_in(d, &["train", "itm", "plain", "-o", "itm", "--steps", "2"]).failure(&["plain", "no bracketed frames"]);
    lucid_in(
        d,
        &["gen", "studio", "--rig", "brackets", "--views", "2,0,1", "--res", "16", "--spp", "1", "-o", "br", "-q"],
    )
    .success();
    lucid_in(d, &["train", "itm", "br", "-o", "itm", "--steps", "2"]).failure(&["smaller than the training patch"]);
    lucid_in(d, &["train", "itm", "br", "-o", "itm", "--set", "train.patch=30"]).failure(&["train.patch"]);
    lucid_in(d, &["train", "itm", "br", "-o", "itm2", "--resume"]).failure(&["nothing to resume"]);
}
