//! The first harmonic's and the trend's standard errors against data this project did not make: campaigns of
//! clean robots from `zmp-indep-sim` (a simulator sharing no code with this crate), whose
//! force-sensor noise is white plus a first-order process of 0.1-1 s correlation time, and
//! whose exact noise the test reads from the drawn robot (identification never sees it).
//!
//! For a stationary noise of per-sample power `P(omega)` (the spectrum in the units of a
//! periodogram bin), the least-squares sine and cosine coefficients over `n` samples have
//! variance `2 P(omega) / n`; over the input's amplitude that is the standard error of one
//! part of `G`. The identification must give it at every frequency, the lowest included,
//! where a record holds only two or three periods. Bounds: the median within 0.85-1.15 (a
//! pooled power of at least 192 degrees of freedom is good to about 10 %, a standard error to
//! about 5 %), every record at least 0.7 of the exact value (too small a standard error is
//! what makes noise look like an effect) and at most 2.5. The standard errors come from the
//! records' period-to-period variation, pooled by frequency (`zmp_identify` `noise`); a record
//! whose own variation is beyond the campaign's at 1 % (Bonferroni over the campaign) keeps
//! its own, and is exempt from the upper bound: its response does not quite repeat, which the
//! sensor's noise, the exact value here, does not see. Each such record must vary beyond the
//! simulator's exact noise: its own
//! period-to-period power over the exact power, a scaled chi-square of its degrees of freedom
//! under the noise alone, beyond the one-sided 1 % point (Wilson and Hilferty's
//! approximation). Before the bins next to the excitation were used, the records at 0.5-2 rad/s of
//! these robots came out 2-4.5 times too small; when the floor was the residual variance
//! times a pooled colour factor, the records of this test ended 0.75-2.3 times the exact
//! value (median 0.99-1.06); with the periods compared with their mean rather than a line
//! through them, 5-7 records a seed (the refined frequency a little off, the response's
//! phasor turning from period to period) kept their own variance at 1.6-4.1 times the exact
//! value.

use std::f64::consts::PI;
use zmp_campaign::read_campaign;
use zmp_files::sections::check_page as doc_section;
use zmp_identify::{identify, IdentifyOptions, NoiseSource};
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions, Scenario};

/// Development seeds whose clean robots have slow coloured noise (correlation 0.6-0.8 s),
/// and one with faster noise.
const SEEDS: [u64; 3] = [43, 50, 47];

/// A clean robot of `seed`, its campaign identified, and its drawn sensor noise.
struct Clean {
    id: zmp_identify::Identification,
    noise: zmp_indep_sim::Noise,
    /// Sample interval, s.
    dt: f64,
}

fn identified_clean(seed: u64, dir: &std::path::Path) -> Clean {
    let design = Design::default();
    let scenario: Scenario = "clean".parse().unwrap();
    let robot = draw_with(
        seed,
        &scenario,
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    let camp_dir = dir.join(format!("c{seed}"));
    write_campaign(&robot, &design, &camp_dir, false).unwrap();
    let camp = read_campaign(&camp_dir).unwrap();
    let id = identify(&camp, &IdentifyOptions::default()).unwrap();
    let dt = 1.0 / camp.sample_rate_hz.expect("the simulator states its rate");
    Clean {
        id,
        noise: robot.sensor.noise,
        dt,
    }
}

#[test]
fn first_harmonic_standard_error_matches_the_simulators_noise() {
    let dir = tempfile::tempdir().unwrap();
    let mut book = String::new();
    for seed in SEEDS {
        let Clean { id, noise, dt } = identified_clean(seed, dir.path());
        let opts = IdentifyOptions::default();
        let phi = (-dt / noise.coloured_tau).exp();
        let mut ratios = Vec::new();
        let mut own = Vec::new();
        let mut lowest = f64::INFINITY;
        for r in id.records.iter().filter(|r| r.excluded.is_none()) {
            let c = r.components.as_ref().expect("an analysed record");
            let x = r.omega * dt;
            let power = noise.white_std.powi(2)
                + noise.coloured_std.powi(2) * (1.0 - phi * phi)
                    / (1.0 - 2.0 * phi * x.cos() + phi * phi);
            let n = r.periods as f64 * 2.0 * PI / r.omega / dt;
            let exact = (2.0 * power / n).sqrt() / r.input_amplitude;
            // Both outputs see the same sensor noise.
            for i in 0..2 {
                // The standard error also carries the identification's relative floor (a
                // model precision, not noise): taken out before the comparison.
                let floor = opts.relative_floor * r.g[i].norm();
                let noise_part = (r.sigma[i].powi(2) - floor * floor).max(0.0).sqrt();
                let q = noise_part / exact;
                let inconsistent = c.noise[i].first.source == NoiseSource::Inconsistent;
                if inconsistent {
                    let own_power = c.noise[i].periods_first;
                    let z = chi2_deviate(own_power.power / power, own_power.dof);
                    assert!(
                        z > 2.326,
                        "seed {seed} record {} output {i} keeps its own noise, {:.2} times the \
                         exact power with {:.1} degrees of freedom (z {z:.2}): not beyond the \
                         noise",
                        r.index,
                        own_power.power / power,
                        own_power.dof
                    );
                    own.push(format!("record {} output {i} x{q:.2}", r.index));
                }
                assert!(
                    q >= 0.7 && (q < 2.5 || inconsistent),
                    "seed {seed} record {} ({:.2} rad/s, {} periods) output {i}: standard \
                     error {:.3e} against the exact {exact:.3e} (x{q:.2}); noise {noise:?}",
                    r.index,
                    r.omega,
                    r.periods,
                    r.sigma[i]
                );
                ratios.push(q);
            }
            lowest = lowest.min(r.omega);
        }
        assert!(lowest <= 0.5 + 1e-9, "the campaign starts at 0.5 rad/s");
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        assert!(
            (0.85..1.15).contains(&median),
            "seed {seed}: median {median:.3} over {} parts",
            ratios.len()
        );
        println!(
            "seed {seed}: {} parts, standard error / exact: min {:.2}, median {median:.2}, max {:.2}; their own: {own:?} (noise {noise:?})",
            ratios.len(),
            ratios[0],
            ratios[ratios.len() - 1]
        );
        book.push_str(&format!(
            "   - seed {seed}, first harmonic: {} parts, min {:.2}, median {median:.2}, \
                 max {:.2}; {} keep their own variance\n",
            ratios.len(),
            ratios[0],
            ratios[ratios.len() - 1],
            own.len()
        ));
    }
    doc_section("docs/src/identification.md", "noise-first-harmonic", &book);
}

/// The standard normal deviate of a scaled chi-square `ratio = X / dof` of `dof` degrees of
/// freedom (Wilson and Hilferty's cube root).
fn chi2_deviate(ratio: f64, dof: f64) -> f64 {
    let a = 2.0 / (9.0 * dof);
    (ratio.cbrt() - (1.0 - a)) / a.sqrt()
}

/// `sum_jk phi^|j-k| w_j w_k` in one pass each way.
fn ar1_form(w: &[f64], phi: f64) -> f64 {
    let mut fwd = vec![0.0; w.len()];
    let mut acc = 0.0;
    for (k, &x) in w.iter().enumerate() {
        acc = phi * acc + x;
        fwd[k] = acc;
    }
    let mut total = 0.0;
    acc = 0.0;
    for k in (0..w.len()).rev() {
        acc = phi * acc + w[k];
        total += w[k] * (fwd[k] + acc - w[k]);
    }
    total
}

/// The trend's standard error (the drift evidence, and a third of every record's error
/// measure) against the exact one: the trend coefficient of the record's regression (DC,
/// trend, three harmonics over its steady window) is a weighted sum `w . e` of the noise,
/// whose variance `sum_jk w_j w_k R(j - k)` the test computes from the drawn noise's
/// autocovariance. Most of the trend's weight lies below one Fourier bin of its window,
/// where the record has no bin of its own; a first-order noise of 0.6-0.8 s is 10-30 times
/// stronger there than two to ten bins up, where the trend's colour was read before: the
/// trend's standard error came out 2-3 times too small (chi-square 4-10 per trend on a
/// clean robot against the right model). Bounds fixed before the first run: median within
/// 0.8-1.25 of the exact value, every record within 0.5-3.
#[test]
fn trend_standard_error_matches_the_simulators_noise() {
    let dir = tempfile::tempdir().unwrap();
    let mut book = String::new();
    for seed in SEEDS {
        let Clean { id, noise, dt } = identified_clean(seed, dir.path());
        let opts = IdentifyOptions::default();
        let phi = (-dt / noise.coloured_tau).exp();
        let mut ratios = Vec::new();
        for r in id.records.iter().filter(|r| r.excluded.is_none()) {
            let c = r.components.as_ref().expect("an analysed record");
            let n = c.samples;
            // The regression's columns over the window; the trend's row of its pseudo-inverse.
            let cols = 2 + 2 * opts.harmonics;
            let x = nalgebra::DMatrix::from_fn(n, cols, |k, j| {
                let t = (k as f64 - (n as f64 - 1.0) / 2.0) * dt;
                match j {
                    0 => 1.0,
                    1 => t,
                    _ => {
                        let h = ((j - 2) / 2 + 1) as f64;
                        let a = h * c.omega * k as f64 * dt;
                        if j % 2 == 0 {
                            a.sin()
                        } else {
                            a.cos()
                        }
                    }
                }
            });
            let xtx_inv = (x.transpose() * &x).try_inverse().expect("full rank");
            let w: Vec<f64> = (xtx_inv.row(1) * x.transpose()).iter().copied().collect();
            let white: f64 = w.iter().map(|v| v * v).sum();
            let exact = (noise.white_std.powi(2) * white
                + noise.coloured_std.powi(2) * ar1_form(&w, phi))
            .sqrt();
            for i in 0..2 {
                let q = c.trend_var(i).sqrt() / exact;
                assert!(
                    (0.5..3.0).contains(&q),
                    "seed {seed} record {} ({:.2} rad/s, {} samples) output {i}: trend standard \
                     error {:.3e} m/s against the exact {exact:.3e} (x{q:.2}); noise {noise:?}",
                    r.index,
                    r.omega,
                    n,
                    c.trend_var(i).sqrt()
                );
                ratios.push(q);
            }
        }
        ratios.sort_by(f64::total_cmp);
        let median = ratios[ratios.len() / 2];
        println!(
            "seed {seed}: {} trends, standard error / exact: min {:.2}, median {median:.2}, max {:.2} (noise {noise:?})",
            ratios.len(),
            ratios[0],
            ratios[ratios.len() - 1]
        );
        assert!(
            (0.8..1.25).contains(&median),
            "seed {seed}: median {median:.3} over {} trends",
            ratios.len()
        );
        book.push_str(&format!(
            "   - seed {seed}, trend: {} trends, min {:.2}, median {median:.2}, max {:.2}\n",
            ratios.len(),
            ratios[0],
            ratios[ratios.len() - 1]
        ));
    }
    doc_section("docs/src/identification.md", "noise-trend", &book);
}
