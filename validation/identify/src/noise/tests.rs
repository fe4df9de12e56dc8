//! Pooling by frequency, its degrees of freedom, and the test of one noise.

use super::*;

fn sample(omega: f64, power: f64, dof: f64) -> Sample {
    Sample { omega, power, dof }
}

#[test]
fn pooling_follows_the_spectrum_by_frequency() {
    // A step in the noise's power at 3 rad/s, samples scattered by +-20 %.
    let samples: Vec<Sample> = (0..30)
        .map(|k| {
            let w = 0.5 * 1.2f64.powi(k);
            let p = if w < 3.0 { 4.0 } else { 1.0 } * if k % 2 == 0 { 1.2 } else { 0.8 };
            sample(w, p, 32.0)
        })
        .collect();
    let r = pool(&samples, &[0.7, 50.0], 1);
    assert!((r[0].power - 4.0).abs() < 0.5, "{r:?}");
    assert!((r[1].power - 1.0).abs() < 0.15, "{r:?}");
    // Nothing to pool: no power.
    assert!(pool(&[], &[1.0], 1)[0].power.is_nan());
}

#[test]
fn a_weighted_mean_has_the_summed_degrees_of_freedom() {
    // Samples at one frequency: their weighted mean, with the summed degrees of freedom.
    let samples = [
        sample(2.0, 1.0, 4.0),
        sample(2.0, 3.0, 12.0),
        sample(2.0, 2.0, 184.0),
    ];
    let p = pool(&samples, &[2.0], 1)[0];
    let want = (4.0 + 36.0 + 368.0) / 200.0;
    assert!((p.power - want).abs() < 1e-12, "{p:?}");
    assert!((p.dof - 200.0).abs() < 1e-9, "{p:?}");
}

#[test]
fn below_the_lowest_sample_the_pool_is_held_not_extrapolated() {
    // A spectrum falling as 1/omega from 1 to 4 rad/s, read at 0.1 rad/s: the line through
    // the samples would go on rising (and hit the clamp); the pool holds the lowest sample's
    // value and is averaged over a trend's nodes like any other query.
    let samples: Vec<Sample> = (0..20)
        .map(|k| {
            let w = 1.0 + 0.15 * k as f64;
            sample(w, 1.0 / w, 20.0)
        })
        .collect();
    let low = pool(&samples, &[0.1], 1)[0];
    let at_one = pool(&samples, &[1.0], 1)[0];
    assert!(
        (low.power - at_one.power).abs() < 1e-12,
        "{low:?} {at_one:?}"
    );
    assert!(low.power > 0.9 && low.power < 1.1, "{low:?}");
    let both = pool(&samples, &[0.1, 1.0], 2)[0];
    assert!((both.power - low.power).abs() < 1e-12);
    // The line's end is less certain than its middle: fewer degrees of freedom than the
    // samples hold, more than one sample's.
    assert!(low.dof < 20.0 * 20.0 && low.dof > 20.0, "{low:?}");
}

#[test]
fn a_record_that_does_not_repeat_keeps_its_own_noise_and_leaves_the_pool() {
    // Forty records at one noise, power 1 with 20 degrees of freedom each (scattered as their
    // chi-square would be), and two that vary ten and four times as much.
    let mut samples: Vec<Sample> = (0..40)
        .map(|k| {
            sample(
                2.0 + 0.01 * k as f64,
                1.0 + 0.3 * ((k as f64 * 2.3).sin()),
                20.0,
            )
        })
        .collect();
    samples.push(sample(2.1, 10.0, 20.0));
    samples.push(sample(2.2, 4.0, 20.0));
    let groups: Vec<std::ops::Range<usize>> = (0..samples.len()).map(|k| k..k + 1).collect();
    let keep = consistent(&samples, &groups);
    assert!(keep[..40].iter().all(|k| *k), "{keep:?}");
    assert!(!keep[40] && !keep[41], "{keep:?}");
    // A campaign of one noise keeps every record.
    let keep = consistent(&samples[..40], &groups[..40]);
    assert!(keep.iter().all(|k| *k));
}

#[test]
fn the_normal_quantile_and_the_f_deviate_match_tables() {
    for (p, z) in [
        (0.5, 0.0),
        (0.975, 1.959_964),
        (0.99, 2.326_348),
        (1.0 - 4.6e-5, 3.911_5),
    ] {
        assert!(
            (normal_quantile(p) - z).abs() < 1e-3,
            "{p}: {}",
            normal_quantile(p)
        );
        assert!((normal_quantile(1.0 - p) + z).abs() < 1e-3);
    }
    // F(10, 200) upper 1 % point 2.41, F(4, 60) 3.65, F(60, 1e9) (chi-square 60 / 60) 1.473.
    for (f, d1, d2) in [(2.41, 10.0, 200.0), (3.65, 4.0, 60.0), (1.473, 60.0, 1e9)] {
        let z = f_deviate(f, d1, d2);
        assert!((z - 2.326).abs() < 0.06, "F({d1}, {d2}) at {f}: z {z}");
    }
}
