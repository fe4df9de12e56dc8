//! The comparison finds where a model fails (a hidden delay shows at high frequency, clean
//! data shows nowhere), the reports are written, the diagnosis's evidence speaks of the delay,
//! and refitting a hand-edited structure recovers the delay the robot has.

use zmp_diagnose::augment::refit_structure;
use zmp_diagnose::candidates::add_effect;
use zmp_diagnose::cells::cells;
use zmp_diagnose::measure::predict;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::{diagnose, DiagnoseOptions};
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, ModelSpec};
use zmp_report::diagnose::{write_compare_report, write_diagnosis_report};
use zmp_suites::blind::paper;
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

const AXES: [Binding; 2] = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];

fn design() -> ExperimentDesign {
    ExperimentDesign {
        operating_points: vec![[0.0, 0.0], [0.02, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 15.0, 7),
        ..ExperimentDesign::reference()
    }
}

fn with_delay(delay: f64) -> ModelSpec {
    let mut m = paper();
    add_effect(&mut m, EffectKind::TimeDelay, &AXES, &[delay]);
    m
}

fn opts() -> DiagnoseOptions {
    DiagnoseOptions {
        campaign_path: "camp".into(),
        model_path: "model.toml".into(),
        threads: 2,
        ..DiagnoseOptions::default()
    }
}

#[test]
fn compare_locates_a_hidden_delay_and_writes_its_reports() {
    let camp = simulate_campaign(&with_delay(0.04), &design()).unwrap();
    let (obs, skipped) = observe_campaign(&camp, 2);
    assert!(skipped.is_empty(), "{skipped:?}");
    let refs: Vec<&Observation> = obs.iter().collect();
    let preds = predict(&paper(), &refs).unwrap();
    let cl = cells(&refs, &preds);
    let bad: Vec<_> = cl.iter().filter(|c| c.significant).collect();
    assert!(!bad.is_empty());
    // A delay's error grows with frequency: the worst cells are in the high band, and no low
    // band cell is worse than a high band one of the same channel and amplitude.
    assert_eq!(bad[0].band, "high", "{:?}", bad[0]);
    for lo in cl.iter().filter(|c| c.band == "low") {
        let hi = cl
            .iter()
            .find(|c| {
                c.band == "high"
                    && c.channel == lo.channel
                    && c.amplitude_m == lo.amplitude_m
                    && c.operating_point_m == lo.operating_point_m
            })
            .unwrap();
        assert!(hi.error > lo.error, "{lo:?} vs {hi:?}");
    }
    let dir = tempfile::tempdir().unwrap();
    let html = write_compare_report(
        &camp,
        "camp",
        "paper",
        &refs,
        &preds,
        &cl,
        &[3],
        dir.path(),
        false,
    )
    .unwrap();
    let text = std::fs::read_to_string(&html).unwrap();
    assert!(text.contains("Where it fails") && text.contains("<svg"));
    assert!(dir.path().join("record_3_time.svg").exists());
    // Existing report files are not overwritten without force.
    assert!(write_compare_report(
        &camp,
        "camp",
        "paper",
        &refs,
        &preds,
        &cl,
        &[3],
        dir.path(),
        false
    )
    .is_err());

    let d = diagnose(&camp, &paper(), &opts(), &|_| {}).unwrap();
    assert_eq!(d.verdict, EffectKind::TimeDelay, "{}", d.to_text());
    let f = &d.findings[0];
    assert!(f.evidence.contains("pure delay"), "{}", f.evidence);
    let delay = f.parameters.values().next().copied().unwrap();
    assert!((delay - 0.04).abs() < 1e-3, "{:?}", f.parameters);
    assert!(f.error_after < 2.0 * d.noise_floor);
    let html = write_diagnosis_report(&camp, &d, &dir.path().join("diag"), false).unwrap();
    let text = std::fs::read_to_string(html).unwrap();
    assert!(
        text.contains("time_delay") && text.contains("Error waterfall") && text.contains("<svg")
    );
}

#[test]
fn clean_data_fails_nowhere() {
    let camp = simulate_campaign(&paper(), &design()).unwrap();
    let (obs, _) = observe_campaign(&camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let preds = predict(&paper(), &refs).unwrap();
    let bad: Vec<_> = cells(&refs, &preds)
        .into_iter()
        .filter(|c| c.significant)
        .collect();
    assert!(bad.is_empty(), "{bad:?}");
}

#[test]
fn refitting_a_hand_edited_structure_recovers_the_delay() {
    let camp = simulate_campaign(&with_delay(0.045), &design()).unwrap();
    // The user added a delay by hand, with a wrong value.
    let edited = with_delay(0.02);
    let r = refit_structure(&camp, &edited, &opts())
        .unwrap()
        .expect("a structure to refit");
    for b in AXES {
        let d = r.spec.value(EffectKind::TimeDelay, b, "delay").unwrap();
        assert!((d - 0.045).abs() < 1e-3, "{b:?}: {d}");
    }
    assert!(r.error_after < r.error_before);
    assert!(
        r.error_after < 2.0 * r.noise_floor,
        "{} vs {}",
        r.error_after,
        r.noise_floor
    );
    // Nothing beyond the core: nothing to refit.
    assert!(refit_structure(&camp, &paper(), &opts()).unwrap().is_none());
}
