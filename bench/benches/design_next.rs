//! `design-next` on the 168-record reference campaign (3 operating points x 2 amplitudes x 14
//! frequencies x 2 channels, 1 mm ZMP noise) of a robot with a play (1 mm) beside a delay
//! (1 ms), with the two rivals the diagnosis fits (the play alone, the play with a delay):
//! as a user runs it (the default target and budget), and with the target out of reach so
//! that the whole budget of 24 records is designed (the worst case); then the same with the
//! play inside the servo's loop (`in_servo = 1`, where a gear's play sits), whose describing
//! functions come from simulation (the slow case). The target: at most 30 s on 2
//! cores.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::time::{Duration, Instant};
use zmp_campaign::Campaign;
use zmp_diagnose::augment::augment_observations;
use zmp_diagnose::design::{design_next, DesignOptions, Rival};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::profiles::DataRange;
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::search::fit_root;
use zmp_diagnose::DiagnoseOptions;
use zmp_models::{Axis, Binding, EffectInstance, EffectKind, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn with(spec: &ModelSpec, kind: EffectKind, values: &[f64]) -> ModelSpec {
    let mut s = spec.clone();
    for a in Axis::BOTH {
        s.insert(EffectInstance {
            info: kind.info(),
            binding: Binding::Axis(a),
            values: values.to_vec(),
        });
    }
    s
}

/// The 168-record campaign of the paper's plant with a play of `width` (`in_servo` its law)
/// beside a 1 ms delay, and the two rivals the diagnosis fits on it.
fn case(paper: &ModelSpec, in_servo: f64) -> (Campaign, Vec<Rival>) {
    let truth = with(
        &with(paper, EffectKind::Backlash, &[0.001, in_servo]),
        EffectKind::TimeDelay,
        &[0.001],
    );
    let design = ExperimentDesign {
        zmp_noise_std: 0.001,
        ..ExperimentDesign::reference()
    };
    let camp = simulate_campaign(&truth, &design).expect("simulate");
    let (obs, _) = observe_campaign(&camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let start = with(paper, EffectKind::Backlash, &[0.0005, in_servo]);
    let play = fit_root(&start, &refs, &DataRange::of(&refs))
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
    (camp, rivals)
}

fn bench(c: &mut Criterion) {
    let paper = ModelSpec::parse(
        include_str!("../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .expect("paper model");
    let mut g = c.benchmark_group("design_next");
    g.sample_size(10).measurement_time(Duration::from_secs(30));
    let cases = [
        ("play_and_delay_168", 0.0, None),
        ("budget_24_168", 0.0, Some(1e6)),
        ("play_in_servo_168", 1.0, None),
    ];
    for (name, in_servo, target) in cases {
        let (camp, rivals) = case(&paper, in_servo);
        let o = DesignOptions {
            threads: 2,
            target_sigma: target,
            ..DesignOptions::default()
        };
        let started = Instant::now();
        let d = design_next(&camp, &rivals, &o, &|_| {}).expect("design-next");
        eprintln!(
            "design_next/{name}: {} records, smallest separation {:.2} -> {:.2} sigma, \
             first run {:.1} s",
            d.records.len(),
            d.path[0],
            d.min_sigma(),
            started.elapsed().as_secs_f64()
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
