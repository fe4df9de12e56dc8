//! The reported standard errors are calibrated: over random parameter sets, the true value
//! lies within 2 reported standard errors of identify(simulate(p)) in 90-98 % of (parameter,
//! case) pairs (a Gaussian estimate with honest errors: 95 %; more means inflated errors,
//! fewer means optimistic ones).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use zmp_identify::{identify, IdentifyOptions};
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

#[test]
fn standard_errors_are_calibrated() {
    let base = ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let cases = 40;
    let (mut inside, mut total) = (0usize, 0usize);
    let mut misses = Vec::new();
    for case in 0..cases {
        let mut spec = base.clone();
        let names = ["a11", "a12", "a21", "a22", "b11", "b12", "b21", "b22"];
        let mut truth = Vec::new();
        for (k, n) in names.iter().enumerate() {
            let v = if k < 4 {
                if k == 0 || k == 3 {
                    rng.gen_range(0.6..1.4)
                } else {
                    rng.gen_range(0.03..0.3)
                }
            } else if k == 4 || k == 7 {
                rng.gen_range(0.05..0.35)
            } else {
                rng.gen_range(0.005..0.1)
            };
            spec.set_value(EffectKind::Pendulum, Binding::Global, n, v);
            truth.push((format!("pendulum.{n}"), v));
        }
        let wn = rng.gen_range(15.0..60.0);
        let zeta = rng.gen_range(0.5..1.5);
        for axis in Axis::BOTH {
            spec.set_value(
                EffectKind::TrackingLowpass,
                Binding::Axis(axis),
                "omega_n",
                wn,
            );
            spec.set_value(
                EffectKind::TrackingLowpass,
                Binding::Axis(axis),
                "zeta",
                zeta,
            );
        }
        truth.push(("tracking_lowpass.omega_n".into(), wn));
        truth.push(("tracking_lowpass.zeta".into(), zeta));
        let design = ExperimentDesign {
            operating_points: vec![[0.0, 0.0]],
            amplitudes: vec![0.003, 0.008],
            omegas: logspace(0.5, 20.0, 10),
            zmp_noise_std: rng.gen_range(0.0002..0.001),
            seed: 100 + case,
            min_steady_s: 6.0,
            ..ExperimentDesign::reference()
        };
        let camp = simulate_campaign(&spec, &design).unwrap();
        let id = identify(&camp, &IdentifyOptions::default()).unwrap();
        let params = id.parameters();
        for (name, v) in &truth {
            let p = params.iter().find(|p| &p.name == name).unwrap();
            if !p.estimated {
                continue;
            }
            total += 1;
            let z = (p.value - v).abs() / p.stderr;
            if z <= 2.0 {
                inside += 1;
            } else {
                misses.push(format!("case {case} {name}: {} vs {v}, {z:.1} se", p.value));
            }
        }
    }
    let coverage = inside as f64 / total as f64;
    eprintln!(
        "coverage within 2 se: {inside}/{total} = {:.1} %",
        100.0 * coverage
    );
    for m in &misses {
        eprintln!("  {m}");
    }
    assert!(total >= 8 * cases as usize);
    assert!(
        (0.90..=0.98).contains(&coverage),
        "coverage within 2 se {coverage}"
    );
}
