//! `lucid lightstage calibrate` on an OLAT capture of `studio` with four chrome reference
//! spheres: every light recovered within a degree of the direction the generator used, and
//! relighting with the recovered directions as good as with the true ones.

use lucid_tests::{lucid_in, temp_dir};

#[test]
fn chrome_spheres_recover_every_light_and_relight_as_the_true_directions_do() {
    let dir = temp_dir();
    let d = dir.path();
    let mut args = vec![
        "gen",
        "studio",
        "--rig",
        "olat",
        "--views",
        "4,0,1",
        "--res",
        "256",
        "--spp",
        "16",
        "--lights",
        "16",
        "--held-out-lights",
        "0",
        "-o",
        "olat",
        "-q",
    ];
    for _ in 0..4 {
        args.extend(["--reference-sphere", "chrome"]);
    }
    lucid_in(d, &args).success();
    let record = std::fs::read_to_string(d.join("olat/dataset.toml")).unwrap();
    assert_eq!(record.matches("kind = \"chrome\"").count(), 4, "{record}");

    let out = lucid_in(d, &["lightstage", "calibrate", "olat", "-o", "directions.json", "--json"]).success().json();
    let lights = out["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 16);
    let mut worst = 0f64;
    for l in lights {
        let error = l["error_degrees"].as_f64().unwrap_or_else(|| panic!("not recovered: {l}"));
        worst = worst.max(error);
    }
    println!("worst angular error {worst:.3}°");
    assert!(worst < 1.0, "a light is {worst}° off");

    let score = |extra: &[&str]| -> Vec<f64> {
        let mut args = vec!["relight", "olat", "--json"];
        args.extend(extra);
        let out = lucid_in(d, &args).success().json();
        out["results"].as_array().unwrap().iter().map(|r| r["psnr"].as_f64().unwrap()).collect()
    };
    let truth = score(&[]);
    let recovered = score(&["--directions", "directions.json"]);
    for (t, r) in truth.iter().zip(&recovered) {
        println!("relit with the recorded directions {t:.2} dB, with the recovered ones {r:.2} dB");
        assert!((t - r).abs() < 1.0, "{t} vs {r}");
    }

    // Refusals: an existing output, a set without spheres, a directions file without a light.
    lucid_in(d, &["lightstage", "calibrate", "olat", "-o", "directions.json"]).failure(&["directions.json", "exists"]);
    lucid_in(
        d,
        &[
            "gen", "studio", "--rig", "olat", "--views", "1,0,0", "--res", "16", "--spp", "1", "--lights", "2", "-o",
            "plain", "-q",
        ],
    )
    .success();
    lucid_in(d, &["lightstage", "calibrate", "plain"]).failure(&["plain", "no chrome reference spheres"]);
    std::fs::write(d.join("partial.json"), r#"{"format":"lucid light directions","version":1,"lights":[]}"#).unwrap();
    lucid_in(d, &["relight", "olat", "--directions", "partial.json"]).failure(&["no direction", "l0"]);
}
