use super::*;

fn small() -> HashGridConfig {
    HashGridConfig {
        levels: 4,
        features_per_level: 2,
        log2_table_size: 10,
        base_resolution: 4.0,
        finest_resolution: 32.0,
        antialias: 0.0,
    }
}

/// A level's footprint weight is the mass of the footprint's Gaussian within half a cell
/// of its centre (Zip-NeRF's reading of it), here integrated numerically; 1 without a
/// footprint or with the weighting off; and the factor scales the footprint.
#[test]
fn footprint_weight_is_the_gaussian_mass_within_half_a_cell() {
    let layout = HashGridConfig { antialias: 1.0, ..small() }.layout();
    let mass = |sigma: f64, half: f64| {
        let n = 20_000;
        let h = 2.0 * half / n as f64;
        (0..n)
            .map(|i| {
                let x = -half + (i as f64 + 0.5) * h;
                (-0.5 * (x / sigma).powi(2)).exp() / (sigma * (2.0 * std::f64::consts::PI).sqrt()) * h
            })
            .sum::<f64>()
    };
    let mut below_one = 0;
    for (l, level) in layout.levels.iter().enumerate() {
        assert_eq!(layout.footprint_weight(l, 0.0), 1.0);
        for sigma in [0.001f32, 0.01, 0.03, 0.1] {
            let want = mass(sigma as f64, 0.5 / level.scale as f64);
            let got = layout.footprint_weight(l, sigma);
            // (Levels whose cells are 1.5 footprints or more wide are taken as 1: 2.3e-5 off.)
            assert!((got as f64 - want).abs() < 3e-5, "level {l}, σ {sigma}: {got} vs {want}");
            below_one += (got < 0.99) as usize;
        }
    }
    assert!(below_one >= 6, "the footprints span the levels' cells");
    let doubled = HashGridConfig { antialias: 2.0, ..small() }.layout();
    assert_eq!(doubled.footprint_weight(3, 0.01), layout.footprint_weight(3, 0.02));
    assert_eq!(small().layout().footprint_weight(3, 0.1), 1.0);
    // Weighing rows multiplies each level's features by its weight, leaving other columns.
    let (width, stride) = (layout.output_dim(), layout.output_dim() + 3);
    let mut rows: Vec<f32> = (0..2 * stride).map(|i| 1.0 + i as f32).collect();
    let before = rows.clone();
    layout.weigh_by_footprint(&mut rows, stride, &[0.0, 0.03]);
    assert_eq!(rows[..stride], before[..stride]);
    for c in 0..stride {
        let w = if c < width { layout.footprint_weight(c / layout.features, 0.03) } else { 1.0 };
        assert_eq!(rows[stride + c], before[stride + c] * w);
    }
}

#[test]
fn layout_levels_grow_geometrically_and_go_from_dense_to_hashed() {
    let layout = small().layout();
    assert!((small().per_level_scale() - 2.0).abs() < 1e-6);
    let scales: Vec<f32> = layout.levels.iter().map(|l| l.scale).collect();
    assert_eq!(scales, [3.0, 7.0, 15.0, 31.0]);
    // 5³ = 125 and 9³ = 729 fit in 1024 rows; 17³ does not.
    assert_eq!(layout.levels.iter().map(|l| l.dense).collect::<Vec<_>>(), [true, true, false, false]);
    assert_eq!(layout.entries, 125 + 729 + 1024 + 1024);
    assert_eq!(layout.levels[2].offset, 125 + 729);
}

#[test]
fn interpolation_weights_sum_to_one_and_reproduce_linear_functions() {
    // Fill a dense level with a linear function of the vertex position in [0,1]³ units;
    // trilinear interpolation must return that function at any point.
    let config = HashGridConfig { levels: 1, features_per_level: 1, log2_table_size: 12, ..small() };
    let layout = config.layout();
    let level = layout.levels[0];
    assert!(level.dense);
    let r = level.resolution;
    let mut table = vec![0.0; layout.entries];
    let lin = |p: [f32; 3]| 0.3 + 1.5 * p[0] - 0.7 * p[1] + 2.0 * p[2];
    for z in 0..r {
        for y in 0..r {
            for x in 0..r {
                // Vertex v sits at x = (v − 0.5)/s in [0,1] units.
                let p = [x, y, z].map(|v| (v as f32 - 0.5) / level.scale);
                table[level.index([x, y, z])] = lin(p);
            }
        }
    }
    for p in [[0.1, 0.2, 0.3], [0.77, 0.01, 0.5], [1.0, 1.0, 0.0], [0.0, 0.5, 0.999]] {
        let weights: f32 = level.corners(p).iter().map(|c| c.1).sum();
        assert!((weights - 1.0).abs() < 1e-6);
        let mut out = [0.0f32];
        layout.forward(&p, &table, &mut out);
        assert!((out[0] - lin(p)).abs() < 1e-4, "{p:?}: {} vs {}", out[0], lin(p));
    }
}

#[test]
fn chunked_encoding_equals_point_by_point_encoding() {
    // Level-by-level with prefetching must give exactly the per-point numbers, into rows
    // wider than the encoding, for chunks shorter and longer than the prefetch distance,
    // for the row widths with their own code (2, 4) and others.
    for f in [1, 2, 3, 4] {
        // Dense and hashed levels, the hashed ones large enough to be prefetched.
        let config = HashGridConfig {
            levels: 6,
            features_per_level: f,
            log2_table_size: 17,
            base_resolution: 16.0,
            finest_resolution: 1024.0,
            antialias: 0.0,
        };
        let layout = config.layout();
        assert!(layout.levels.iter().any(|l| l.dense) && layout.levels.iter().any(|l| !l.dense));
        assert!(layout.levels.iter().any(|l| l.size * f * 4 > PREFETCH_ABOVE_BYTES));
        let width = layout.output_dim();
        let stride = width + 5;
        let table: Vec<f32> = (0..layout.entries * f).map(|i| (i as f32 * 0.618_034).fract() - 0.5).collect();
        for n in [0, 1, AHEAD - 1, AHEAD + 3, 200] {
            let positions: Vec<f32> = (0..n * 3).map(|i| (i as f32 * 0.377_91).fract() * 1.1 - 0.05).collect();
            let mut act = vec![7.0f32; n * stride];
            layout.encode_chunk(&positions, &table, &mut act, stride);
            for i in 0..n {
                let mut want = vec![0.0; width];
                layout.encode_point([positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]], &table, &mut want);
                assert_eq!(act[i * stride..i * stride + width], want[..], "F={f}, n={n}, point {i}");
                assert!(act[i * stride + width..(i + 1) * stride].iter().all(|&v| v == 7.0), "wrote past the encoding");
            }
        }
    }
}

#[test]
fn backward_is_the_transpose_of_forward() {
    // The encoding is linear in the table: <grad_out, forward(table)> = <backward(grad_out), table>
    // (for the row widths with their own code, 2 and 4, and another).
    for f in [2, 3, 4] {
        let layout = HashGridConfig { features_per_level: f, ..small() }.layout();
        let n = 300;
        let positions: Vec<f32> = (0..n * 3).map(|i| (i as f32 * 0.618_034).fract()).collect();
        let table: Vec<f32> = (0..layout.entries * f).map(|i| (i as f32 * 0.414_213_6).fract() - 0.5).collect();
        let grad_out: Vec<f32> = (0..n * layout.output_dim()).map(|i| (i as f32 * 0.732_050_8).fract() - 0.5).collect();
        let mut out = vec![0.0; n * layout.output_dim()];
        layout.forward(&positions, &table, &mut out);
        let mut grad_table = vec![0.0; table.len()];
        layout.backward(&positions, &grad_out, &mut grad_table);
        let lhs: f64 = out.iter().zip(&grad_out).map(|(a, b)| (*a as f64) * (*b as f64)).sum();
        let rhs: f64 = grad_table.iter().zip(&table).map(|(a, b)| (*a as f64) * (*b as f64)).sum();
        assert!((lhs - rhs).abs() < 1e-3 * lhs.abs().max(1.0), "F={f}: {lhs} vs {rhs}");
    }
}

#[test]
fn bad_configs_are_rejected() {
    assert!(HashGridConfig::default().validate().is_ok());
    let bad = [
        HashGridConfig { levels: 0, ..Default::default() },
        HashGridConfig { log2_table_size: 40, ..Default::default() },
        HashGridConfig { base_resolution: f32::NAN, ..Default::default() },
        HashGridConfig { finest_resolution: 8.0, ..Default::default() },
        HashGridConfig { finest_resolution: -1.0, ..Default::default() },
        HashGridConfig { finest_resolution: f32::INFINITY, ..Default::default() },
    ];
    for c in bad {
        assert!(c.validate().is_err(), "{c:?}");
    }
}

#[test]
fn the_views_choose_the_finest_resolution_by_their_pixel_footprint() {
    let auto = HashGridConfig::default();
    assert_eq!(auto.finest_resolution, 0.0);
    // Unchosen, it stands for instant-ngp's, and the level scales follow from that.
    assert_eq!(auto.finest(), INSTANT_NGP_FINEST);
    let fixed = HashGridConfig { finest_resolution: INSTANT_NGP_FINEST, ..auto };
    assert_eq!(auto.layout(), fixed.layout());
    // instant-ngp's NeRF-synthetic views (800 px, f = 1111.1 px, 4.03 from the centre of the
    // 3-unit box) choose about its 2048; views of a quarter the size a quarter of that.
    let lego = auto.finest_for_views(3.0, 1.0 / 1111.1, 4.031);
    assert!((lego - 2.5 * 3.0 * 1111.1 / 4.031).abs() < 1e-2 && (lego / 2048.0 - 1.0).abs() < 0.01, "{lego}");
    let quarter = auto.finest_for_views(3.0, 4.0 / 1111.1, 4.031);
    assert!((quarter * 4.0 - lego).abs() < 1e-2, "{quarter}");
    // Bounded by the base resolution and the cap; degenerate views leave it unchosen.
    assert_eq!(auto.finest_for_views(3.0, 0.5, 100.0), auto.base_resolution);
    assert_eq!(auto.finest_for_views(3.0, 1e-6, 1.0), MAX_CHOSEN_FINEST);
    assert_eq!(auto.finest_for_views(3.0, 0.0, 4.0), INSTANT_NGP_FINEST);
    assert_eq!(auto.finest_for_views(f32::NAN, 0.001, 4.0), INSTANT_NGP_FINEST);
}
