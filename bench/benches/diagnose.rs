//! The full diagnosis of a 168-record campaign (the reference design: 3 operating points x 2
//! amplitudes x 14 frequencies x 2 channels) against the model identified from it: every
//! catalogued structure of the search fitted and scored on held-out records. Two hidden
//! robots: the demo's (40 ms servo latency + a drifting ZMP sensor: two effects)
//! and one with Coulomb friction (the costliest candidate family: simulated describing
//! functions). The describing-function cache is cleared at the start of every diagnosis.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::time::Duration;
use zmp_campaign::Campaign;
use zmp_diagnose::{diagnose, DiagnoseOptions};
use zmp_identify::{identify, IdentifyOptions};
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, EffectInstance, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn robot(effects: &[(EffectKind, Binding, Vec<f64>)]) -> (Campaign, ModelSpec) {
    let mut spec = ModelSpec::parse(
        include_str!("../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .expect("paper model");
    for (kind, b, v) in effects {
        spec.insert(EffectInstance {
            info: kind.info(),
            binding: *b,
            values: v.clone(),
        });
    }
    let camp = simulate_campaign(&spec, &ExperimentDesign::reference()).expect("simulate");
    let model = identify(&camp, &IdentifyOptions::default())
        .expect("identify")
        .model;
    (camp, model)
}

fn bench(c: &mut Criterion) {
    let x = Binding::Axis(Axis::X);
    let y = Binding::Axis(Axis::Y);
    let cases = [
        (
            "delay_and_drift_168",
            robot(&[
                (EffectKind::TimeDelay, x, vec![0.04]),
                (EffectKind::TimeDelay, y, vec![0.04]),
                (EffectKind::SensorDrift, y, vec![0.0, 3e-5]),
            ]),
            EffectKind::TimeDelay,
        ),
        (
            "friction_168",
            robot(&[
                (EffectKind::CoulombFriction, x, vec![0.3]),
                (EffectKind::CoulombFriction, y, vec![0.3]),
            ]),
            EffectKind::CoulombFriction,
        ),
    ];
    let opts = DiagnoseOptions::default();
    let mut g = c.benchmark_group("diagnose");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    for (name, (camp, model), expect) in &cases {
        let d = diagnose(camp, model, &opts, &|_| {}).expect("diagnose");
        assert_eq!(d.verdict.name(), expect.name(), "{}", d.to_text());
        g.bench_function(*name, |b| {
            b.iter(|| black_box(diagnose(camp, model, &opts, &|_| {}).expect("diagnose")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
