//! The diagnosis core on a virtual campaign with a hidden pure delay: the error measure sees
//! it, the delay candidate recovers it, and its held-out error falls to the noise floor.

use zmp_diagnose::candidates::CATALOGUE;
use zmp_diagnose::engine::{control, evaluate, own_parameters, score_candidate};
use zmp_diagnose::measure::aggregate;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::select::gain;
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, EffectInstance, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn paper() -> ModelSpec {
    ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap()
}

fn design() -> ExperimentDesign {
    ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 15.0, 8),
        excited: vec![Axis::X, Axis::Y],
        ..ExperimentDesign::reference()
    }
}

fn observations(spec: &ModelSpec) -> Vec<Observation> {
    let camp = simulate_campaign(spec, &design()).unwrap();
    let (obs, skipped) = observe_campaign(&camp, 2);
    assert!(skipped.is_empty(), "{skipped:?}");
    obs
}

#[test]
fn true_model_scores_at_the_noise_floor() {
    let spec = paper();
    let obs = observations(&spec);
    let o: Vec<&Observation> = obs.iter().collect();
    let (e, f) = aggregate(&evaluate(&spec, &o).unwrap());
    assert!(e < 1.5 * f, "error {e} vs floor {f}");
    assert!(e > 0.5 * f, "error {e} implausibly below floor {f}");
}

#[test]
fn hidden_delay_is_seen_and_recovered() {
    let mut truth = paper();
    let info = EffectKind::TimeDelay.info();
    for a in Axis::BOTH {
        truth.insert(EffectInstance {
            info,
            binding: Binding::Axis(a),
            values: vec![0.02],
        });
    }
    let obs = observations(&truth);
    let o: Vec<&Observation> = obs.iter().collect();
    let base = paper();
    let (e0, f) = aggregate(&evaluate(&base, &o).unwrap());
    assert!(
        e0 > 5.0 * f,
        "a 20 ms delay must show: error {e0}, floor {f}"
    );
    let cand = CATALOGUE
        .iter()
        .find(|c| c.effect == EffectKind::TimeDelay)
        .unwrap();
    let scored = score_candidate(cand, &base, &o).unwrap();
    let p = own_parameters(&scored);
    let tau = p.values().next().copied().unwrap().0;
    assert!(
        (tau - 0.02).abs() < 5e-4,
        "fitted delay {tau} s, truth 0.02 s ({p:?})"
    );
    assert!(
        scored.error < 2.0 * f,
        "held-out error {} vs floor {f}",
        scored.error
    );
    // Against the model's own structure refitted, the delay passes the held-out test.
    let root = control(&base, &o).unwrap();
    let g = gain(&root, &scored);
    assert!(g.significant(), "{g:?}");
    assert!(g.total_fraction > 0.9, "{g:?}");
}
