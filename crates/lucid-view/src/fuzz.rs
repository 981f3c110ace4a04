//! The viewer's request parsers against damaged and random input: a request head (what
//! `httparse` and the server make of it) and a URL (routes and their numbers). Neither may
//! panic; each reads or refuses with a 4xx status and a reason. A fixed number of cases from a
//! fixed seed (`FUZZ_CASES`, default 512), as the file readers' fuzzers.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

use super::requests::parse;
use super::server::parse_head_for_tests;

fn config() -> Config {
    let cases = std::env::var("FUZZ_CASES").ok().and_then(|s| s.parse().ok()).unwrap_or(512);
    Config { cases, rng_seed: RngSeed::Fixed(0x51e_77e5), failure_persistence: None, ..Config::default() }
}

/// Numbers that break careless parsers.
const EXTREMES: [&str; 12] =
    ["0", "-1", "-0", "1e30", "nan", "inf", "-inf", "4294967297", "179.999999", "1e-45", "99999999999999999999", ""];

const VALID: &str = "/api/render?c2w=1%2C0%2C0%2C0%2C0%2C1%2C0%2C0%2C0%2C0%2C1%2C4%2C0%2C0%2C0%2C1&fov=50&w=40&h=30\
                     &aperture=0.1&focus=3&lens_rays=8&mode=depth&format=rgb";

/// A render URL whose numbers are each valid or extreme; a valid URL cut or with bytes
/// changed; a route with a random query; random text.
fn urls() -> BoxedStrategy<String> {
    let value = |valid: &'static str| prop_oneof![2 => Just(valid.to_string()), 1 => (0..EXTREMES.len()).prop_map(|e| EXTREMES[e].to_string())];
    // The identity pose 4 units up, each entry kept or (one time in sixteen) made extreme.
    let identity = ["1", "0", "0", "0", "0", "1", "0", "0", "0", "0", "1", "4", "0", "0", "0", "1"];
    let pose = prop::collection::vec((0..16usize, 0..EXTREMES.len()), 16).prop_map(move |picks| {
        let entries: Vec<&str> =
            picks.iter().enumerate().map(|(i, &(k, e))| if k > 0 { identity[i] } else { EXTREMES[e] }).collect();
        entries.join("%2C")
    });
    let render = (pose, value("50"), value("40"), value("30"), value("0.1"), value("3"), value("8"), value("2"))
        .prop_map(|(c2w, fov, w, h, a, f, rays, x)| {
            format!("/api/depth?c2w={c2w}&fov={fov}&w={w}&h={h}&aperture={a}&focus={f}&lens_rays={rays}&x={x}&y={x}")
        });
    let routes = ["/api/render?", "/api/depth?x=3&y=2&", "/api/truth?", "/api/compare?", "/", "/api/info"];
    prop_oneof![
        4 => render,
        1 => (0..VALID.len()).prop_map(|cut| VALID[..cut].to_string()),
        2 => prop::collection::vec((0..VALID.len(), any::<u8>()), 1..6).prop_map(|edits| {
            let mut bytes = VALID.as_bytes().to_vec();
            for (i, v) in edits {
                bytes[i] = v;
            }
            String::from_utf8_lossy(&bytes).into_owned()
        }),
        2 => (0..routes.len(), "[a-z_=&%0-9.,-]{0,80}").prop_map(move |(r, q)| format!("{}{q}", routes[r])),
        1 => any::<String>(),
    ]
    .boxed()
}

#[test]
fn urls_are_read_or_refused_with_a_reason() {
    let mut runner = TestRunner::new(config());
    runner
        .run(&urls(), |url| {
            if let Err(refusal) = parse(&url) {
                prop_assert!((400..=431).contains(&refusal.status), "{url}: {}", refusal.status);
                prop_assert!(!refusal.reason.is_empty(), "{url}");
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn request_heads_are_read_or_refused_with_a_reason() {
    let valid = "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:7007\r\nOrigin: http://127.0.0.1:7007\r\n\
                 Content-Length: 0\r\n\r\n";
    let heads = prop_oneof![
        3 => prop::collection::vec((0..valid.len(), any::<u8>()), 1..8).prop_map(move |edits| {
            let mut bytes = valid.as_bytes().to_vec();
            for (i, v) in edits {
                bytes[i] = v;
            }
            bytes
        }),
        1 => (0..valid.len()).prop_map(move |cut| valid.as_bytes()[..cut].to_vec()),
        1 => prop::collection::vec(any::<u8>(), 0..300),
        1 => (0..EXTREMES.len()).prop_map(move |e| valid.replace("Length: 0", &format!("Length: {}", EXTREMES[e])).into_bytes()),
    ];
    let mut runner = TestRunner::new(config());
    runner
        .run(&heads, |bytes| {
            if let Err(status) = parse_head_for_tests(&bytes) {
                prop_assert!((400..=431).contains(&status), "{status}");
            }
            Ok(())
        })
        .unwrap();
}
