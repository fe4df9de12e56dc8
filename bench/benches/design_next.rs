//! `design-next` on the 168-record reference campaign (3 operating points x 2 amplitudes x 14
//! frequencies x 2 channels, 1 mm ZMP noise) of a robot with a play (1 mm) beside a delay
//! (1 ms), with the two rivals the diagnosis fits (the play alone, the play with a delay):
//! as a user runs it (the default target and budget), and with the target out of reach so
//! that the whole budget of 24 records is designed (the worst case). The target:
//! at most 30 s on 2 cores.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::time::Duration;
use zmp_diagnose::augment::augment_observations;
use zmp_diagnose::design::{design_next, DesignOptions, Rival};
use zmp_diagnose::engine::refit_all;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::DiagnoseOptions;
use zmp_models::{Axis, Binding, EffectInstance, EffectKind, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn with(spec: &ModelSpec, kind: EffectKind, value: f64) -> ModelSpec {
    let mut s = spec.clone();
    for a in Axis::BOTH {
        s.insert(EffectInstance {
            info: kind.info(),
            binding: Binding::Axis(a),
            values: vec![value],
        });
    }
    s
}

fn bench(c: &mut Criterion) {
    let paper = ModelSpec::parse(
        include_str!("../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .expect("paper model");
    let truth = with(
        &with(&paper, EffectKind::Backlash, 0.001),
        EffectKind::TimeDelay,
        0.001,
    );
    let design = ExperimentDesign {
        zmp_noise_std: 0.001,
        ..ExperimentDesign::reference()
    };
    let camp = simulate_campaign(&truth, &design).expect("simulate");
    let (obs, _) = observe_campaign(&camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let play = refit_all(&with(&paper, EffectKind::Backlash, 0.0005), &refs)
        .expect("refit")
        .spec;
    let opts = DiagnoseOptions {
        threads: 2,
        ..DiagnoseOptions::default()
    };
    let both = augment_observations(&refs, &play, "time_delay", &opts)
        .expect("augment")
        .spec;
    let rivals = vec![
        Rival {
            label: "play.toml".into(),
            spec: play,
        },
        Rival {
            label: "play+delay.toml".into(),
            spec: both,
        },
    ];
    let mut g = c.benchmark_group("design_next");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    for (name, target) in [("play_and_delay_168", 5.0), ("budget_24_168", 1e6)] {
        let o = DesignOptions {
            threads: 2,
            target_sigma: target,
            ..DesignOptions::default()
        };
        let d = design_next(&camp, &rivals, &o, &|_| {}).expect("design-next");
        eprintln!(
            "design_next/{name}: {} records, smallest separation {:.2} -> {:.2} sigma",
            d.records.len(),
            d.path[0],
            d.min_sigma()
        );
        assert!(!d.records.is_empty());
        g.bench_function(name, |b| {
            b.iter(|| black_box(design_next(&camp, &rivals, &o, &|_| {}).expect("design-next")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
