//! Profiles, one effect at a time: the effect simulated alone on the virtual robot (the
//! seed's model plus the effect; the standard test campaign: 3 and 8 mm sines, 8 frequencies
//! from 0.5 to 15 rad/s, both axes), diagnosed against the seed's model, must be named alone
//! with its parameters within stated tolerances. The delay's is in `diagnose_core.rs`.

use zmp_diagnose::{diagnose, Candidate, DiagnoseOptions, Law, Verdict};
use zmp_models::{logspace, Axis, EffectKind, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

const PAPER: &str = include_str!("../../../models/params/silo2-paper.toml");

fn design() -> ExperimentDesign {
    ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 15.0, 8),
        excited: vec![Axis::X, Axis::Y],
        ..ExperimentDesign::reference()
    }
}

/// Diagnoses the seed's model on a campaign of the seed's model plus `extra` (TOML); the
/// verdict must name `kind` under `law`, and every fitted parameter named `param` must lie
/// within `rel` of `truth`.
fn named(extra: &str, kind: EffectKind, law: Law, param: &str, truth: f64, rel: f64) {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth_spec = ModelSpec::parse(&format!("{PAPER}\n{extra}"), "truth.toml").unwrap();
    let camp = simulate_campaign(&truth_spec, &design()).unwrap();
    let opts = DiagnoseOptions {
        threads: 2,
        ..DiagnoseOptions::default()
    };
    let d = diagnose(&camp, &paper, &opts, &|_| {}).unwrap();
    assert_eq!(
        d.verdict,
        Verdict::Effect(Candidate::new(kind, law)),
        "{}",
        d.to_text()
    );
    assert_eq!(d.selected.len(), 1, "the effect alone: {}", d.to_text());
    let f = &d.findings[0];
    let fitted: Vec<f64> = f
        .parameters
        .iter()
        .filter(|(n, _)| n.ends_with(param))
        .map(|(_, v)| *v)
        .collect();
    assert!(!fitted.is_empty(), "{:?}", f.parameters);
    for v in fitted {
        assert!(
            (v / truth - 1.0).abs() < rel,
            "{param} = {v}, truth {truth}"
        );
    }
    assert!(d.explained, "{}", d.to_text());
}

/// A ZMP sensor filtered at 20 rad/s (37 degrees of lag at the top of the sweep): its cutoff
/// within 5 % (the lag is measured to a fraction of a degree on every record).
#[test]
fn a_sensor_lowpass_is_named_with_its_cutoff() {
    named(
        "[sensor_lowpass]\ncutoff = 20.0\n",
        EffectKind::SensorLowpass,
        Law::Only,
        "cutoff",
        20.0,
        0.05,
    );
}

/// A ZMP sensor whose offset drifts at 0.02 mm/s (1.2 mm over a minute-long record): its rate
/// within 10 % (the trend of each record is fitted with its own standard error).
#[test]
fn a_sensor_drift_is_named_with_its_rate() {
    named(
        "[sensor_drift]\noffset = 0.0\nrate = 2e-5\n",
        EffectKind::SensorDrift,
        Law::Only,
        "rate",
        2e-5,
        0.10,
    );
}

/// A play of 0.6 mm on the CoM command (a fifth of the small sine): its width within 15 %
/// (the play's lag and gain loss on the 3 mm sines carry it; the 8 mm ones barely see it).
#[test]
#[ignore = "long: about 100 s on 2 cores (the play's describing functions are simulated)"]
fn a_play_on_the_command_is_named_with_its_width() {
    named(
        "[backlash]\nwidth = 0.0006\n",
        EffectKind::Backlash,
        Law::OnCommand,
        "width",
        0.0006,
        0.15,
    );
}
