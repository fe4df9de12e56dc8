//! The diagnosis refuses what it cannot judge, with errors that name the file and the cause,
//! says `unexplained` for an effect outside its catalogue, and its JSON keeps the
//! `zmp-diagnosis/1` fields.

use zmp_diagnose::augment::augment;
use zmp_diagnose::run::Subject;
use zmp_diagnose::{diagnose, DiagnoseOptions, Verdict};
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, EffectInstance};
use zmp_suites::blind::paper;
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn design(omegas: Vec<f64>) -> ExperimentDesign {
    ExperimentDesign {
        operating_points: vec![[0.0, 0.0], [0.02, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas,
        ..ExperimentDesign::reference()
    }
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
fn one_frequency_is_an_error() {
    let camp = simulate_campaign(&paper(), &design(vec![2.0])).unwrap();
    let e = diagnose(&camp, &paper(), &opts(), &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("camp: "), "{e}");
    assert!(e.contains("1 frequency (2 rad/s)"), "{e}");
}

#[test]
fn model_channels_must_match_the_campaign() {
    let camp = simulate_campaign(&paper(), &design(logspace(0.5, 15.0, 5))).unwrap();
    let mut no_g11 = paper();
    no_g11.set_value(EffectKind::Pendulum, Binding::Global, "a11", 0.0);
    no_g11.set_value(EffectKind::Pendulum, Binding::Global, "b11", 0.0);
    let e = diagnose(&camp, &no_g11, &opts(), &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("model.toml: "), "{e}");
    assert!(e.contains("no G11 channel"), "{e}");
    // Off by a factor of twenty: another robot, other units or a wrong file.
    let mut scaled = paper();
    for p in ["a11", "a12", "a21", "a22", "b11", "b12", "b21", "b22"] {
        let v = scaled
            .value(EffectKind::Pendulum, Binding::Global, p)
            .unwrap();
        scaled.set_value(EffectKind::Pendulum, Binding::Global, p, 0.05 * v);
    }
    let e = diagnose(&camp, &scaled, &opts(), &|_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("does not describe this campaign"), "{e}");
    let e = augment(&camp, &paper(), "gremlins", &opts())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unknown effect \"gremlins\"") && e.contains("time_delay"),
        "{e}"
    );
}

#[test]
fn clean_data_is_none_and_json_keeps_the_spec_fields() {
    let camp = simulate_campaign(&paper(), &design(logspace(0.5, 15.0, 6))).unwrap();
    let d = diagnose(&camp, &paper(), &opts(), &|_| {}).unwrap();
    assert_eq!(d.verdict, Verdict::None, "{}", d.to_text());
    let j = d.to_json();
    assert_eq!(j["format"], "zmp-diagnosis/1");
    for k in [
        "campaign",
        "model",
        "noise_floor",
        "baseline_error",
        "verdict",
        "findings",
    ] {
        assert!(!j[k].is_null(), "missing {k}");
    }
    assert!(j["baseline_error"].as_f64().unwrap() <= 1.5 * j["noise_floor"].as_f64().unwrap());
}

#[test]
fn an_effect_outside_the_catalogue_is_unexplained() {
    // A random stable perturbation of G11 alone, up to 15 % at high frequency (the seed's
    // multiplicative uncertainty with a drawn Delta): no catalogued effect reproduces it.
    let mut truth = paper();
    let u = EffectKind::Uncertainty.info();
    truth.insert(EffectInstance {
        info: u,
        binding: Binding::Channel(zmp_models::Channel::new(Axis::X, Axis::X)),
        values: vec![0.15, 0.3, 3.0, 1.0, 3.0],
    });
    let camp = simulate_campaign(&truth, &design(logspace(0.5, 15.0, 8))).unwrap();
    let d = diagnose(&camp, &paper(), &opts(), &|_| {}).unwrap();
    println!("{}", d.to_text());
    assert!(d.baseline_error > 3.0 * d.noise_floor);
    assert_eq!(d.verdict, Verdict::Unexplained, "{}", d.to_text());
    let f = &d.findings[0];
    assert_eq!(f.effect, Subject::Unexplained);
    assert!(f.channels.iter().any(|c| c == "G11"), "{:?}", f.channels);
    // Where it still fails: the cells left, or the residual described in words.
    assert!(
        !f.remaining.is_empty() || !d.residual.is_empty(),
        "{}",
        d.to_text()
    );
}
