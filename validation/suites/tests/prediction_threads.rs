//! The prediction of a nonlinear model shares its frequencies out over the thread budget
//! (`zmp_campaign::par`): one thread, two or three give the same predictions to the bit
//! (each describing function is computed by one worker from the same inputs), and inside a
//! pool's worker the budget is one thread plus the pool's idle workers, not the caller's again
//! (the instruction-count benches ask for one thread and count only the thread they run on).

use zmp_campaign::par::{budget, parallel_map, with_deadline, with_threads};
use zmp_diagnose::candidates::add_effect;
use zmp_diagnose::measure::{predict, predict_in_time, predict_until};
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::observe_campaign;
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding};
use zmp_suites::blind::paper;
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

#[test]
fn predictions_do_not_depend_on_the_thread_budget() {
    let axes = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
    let mut robot = paper();
    add_effect(&mut robot, EffectKind::Backlash, &axes, &[0.001]);
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 12.0, 5),
        ..ExperimentDesign::reference()
    };
    let camp = simulate_campaign(&robot, &design).unwrap();
    let (obs, skipped) = observe_campaign(&camp, 2);
    assert!(skipped.is_empty(), "{skipped:?}");
    let refs: Vec<&Observation> = obs.iter().collect();
    assert!(refs.len() >= 12, "{} observations", refs.len());
    // A play and an acceleration limit that the fastest, largest records reach: describing
    // functions simulated by the servo.
    let mut model = paper();
    add_effect(&mut model, EffectKind::Backlash, &axes, &[0.0012]);
    add_effect(
        &mut model,
        EffectKind::AccelerationSaturation,
        &axes,
        &[0.6],
    );
    let bits = |threads: usize| {
        zmp_models::effects::servo::clear_describing_function_cache();
        let p = with_threads(threads, || predict(&model, &refs)).unwrap();
        p.iter()
            .flat_map(|p| {
                (0..2).flat_map(move |i| {
                    [p.g[i].re, p.g[i].im, p.g3[i].re, p.g3[i].im].map(f64::to_bits)
                })
            })
            .collect::<Vec<_>>()
    };
    let one = bits(1);
    // The play is seen: the predictions are not the linear model's.
    let linear = predict(&paper(), &refs).unwrap();
    let p1 = with_threads(1, || predict(&model, &refs)).unwrap();
    let moved = p1
        .iter()
        .zip(&linear)
        .filter(|(a, b)| (a.g[0] - b.g[0]).norm() > 1e-3 * b.g[0].norm())
        .count();
    assert!(
        moved >= 4,
        "only {moved} predictions differ from the linear model's"
    );
    assert_eq!(bits(2), one);
    assert_eq!(bits(3), one);
    // Inside a worker of a pool the budget is one thread plus the pool's idle workers, never
    // the caller's whole budget again.
    let inner = with_threads(2, || parallel_map(3, 2, |_| budget()));
    assert!(inner.iter().all(|b| (1..=2).contains(b)), "{inner:?}");
}

/// A fit's prediction stops once the time limit of its work has passed, checked before each
/// record, so that one evaluation of a slow model cannot run far past the limit (held-out draw
/// 1240030, limited to 600 s, ended after 809 s inside one evaluation of a model with a
/// friction); before the limit it predicts exactly what `predict` does.
#[test]
fn a_prediction_in_time_stops_at_the_limit_record_by_record() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::time::{Duration, Instant};
    let axes = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 12.0, 5),
        ..ExperimentDesign::reference()
    };
    let camp = simulate_campaign(&paper(), &design).unwrap();
    let (obs, _) = observe_campaign(&camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    assert!(refs.len() >= 12, "{} observations", refs.len());
    let mut model = paper();
    add_effect(&mut model, EffectKind::CoulombFriction, &axes, &[0.05]);
    let bits = |p: &[zmp_diagnose::measure::Prediction]| -> Vec<u64> {
        p.iter()
            .flat_map(|p| (0..2).flat_map(move |i| [p.g[i].re, p.g[i].im].map(f64::to_bits)))
            .collect()
    };
    let all = bits(&predict(&model, &refs).unwrap());
    for threads in [1, 2] {
        with_threads(threads, || {
            let past = Instant::now() - Duration::from_millis(1);
            let stopped = with_deadline(Some(past), || predict_in_time(&model, &refs)).unwrap();
            assert!(
                stopped.is_none(),
                "{threads} threads: predicted past the limit"
            );
            let later = Instant::now() + Duration::from_secs(3600);
            let p = with_deadline(Some(later), || predict_in_time(&model, &refs))
                .unwrap()
                .expect("within the limit");
            assert_eq!(bits(&p), all, "{threads} threads");
            assert!(
                predict_in_time(&model, &refs).unwrap().is_some(),
                "no limit"
            );
        });
    }
    // Record by record: a stop that turns true before the fourth record is asked four times
    // on one thread, not once per prediction and not once per record to the end.
    let asked = AtomicUsize::new(0);
    let stop = || asked.fetch_add(1, Ordering::Relaxed) >= 3;
    let stopped = with_threads(1, || predict_until(&model, &refs, &stop)).unwrap();
    assert!(stopped.is_none());
    assert_eq!(asked.load(Ordering::Relaxed), 4);
}
